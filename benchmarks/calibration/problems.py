"""Synthetic calibration problems of the DEM kind, for benchmarks/calibration/run.py.

Each problem has named parameters with SI-like bounds, noise-free bulk
responses in closed form (smooth, monotone, saturating in the frictions, as
DEM bulk responses are), targets = the responses at a hidden true point (so
the lowest true objective is 0), a measurement spread per target (kept as
metadata, like demcal's ``Target.spread``), and Gaussian simulation noise
per response. The noise standard deviation of a response is ``sd_rel``
times its target value, the same everywhere in the box.

Objective: Samuelsson (2023) eq. 3.3 with unit weights, the sum over the
responses of ((y - r) / r)^2, with y the replicate mean. The *true
objective* of a point is eq. 3.3 of its noise-free responses. The *noise
level* is the expected eq. 3.3 of the noise alone at the true point:
sum over the responses of sd_rel^2 / replicates.

Noise is seeded per (problem, seed, evaluation index k): the k-th
evaluation of every tool with the same seed sees the same draws, whichever
process or venv makes it (``noisy_responses``). Pure NumPy; imported by the
harness (NumPy 2) and by worker_np1.py (NumPy 1), so nothing else here.
"""

from __future__ import annotations

import math
import time
import zlib
from dataclasses import dataclass, field

import numpy as np

NOISE_KEY = 20_231_103  # fixed root of the noise streams


def saturating(value: float, scale: float) -> float:
    """1 - exp(-value/scale): rises from 0 and levels off, like a bulk response in a friction."""
    return 1.0 - math.exp(-value / scale)


@dataclass(frozen=True)
class Response:
    """One measured response: ``key`` is demcal's ``scene.response``."""

    key: str
    unit: str
    sd_rel: float  # simulation noise, sd / target
    spread_rel: float  # measurement spread of the target, sd / target


@dataclass(frozen=True)
class Problem:
    name: str
    description: str
    parameters: tuple[str, ...]
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    truth: tuple[float, ...]
    responses: tuple[Response, ...]
    model: object = field(repr=False)  # x (tuple of floats, real units) -> tuple of response values
    replicates: int = 1

    @property
    def dimension(self) -> int:
        return len(self.parameters)

    @property
    def keys(self) -> list[str]:
        return [r.key for r in self.responses]

    def response_values(self, x) -> dict[str, float]:
        """Noise-free responses at x (real units)."""
        values = self.model(tuple(float(v) for v in x))
        return dict(zip(self.keys, (float(v) for v in values)))

    @property
    def targets(self) -> dict[str, float]:
        return self.response_values(self.truth)

    @property
    def spreads(self) -> dict[str, float]:
        """Measurement standard deviation of each target, in its unit."""
        targets = self.targets
        return {r.key: r.spread_rel * targets[r.key] for r in self.responses}

    @property
    def noise_sd(self) -> dict[str, float]:
        targets = self.targets
        return {r.key: r.sd_rel * targets[r.key] for r in self.responses}

    @property
    def noise_level(self) -> float:
        """Expected eq. 3.3 of the noise alone at the true point."""
        return sum(r.sd_rel**2 for r in self.responses) / self.replicates

    def squared_errors(self, mean_responses: dict[str, float]) -> list[float]:
        """((y - r) / r)^2 per response, in the order of ``keys``."""
        targets = self.targets
        return [((mean_responses[k] - targets[k]) / targets[k]) ** 2 for k in self.keys]

    def objective(self, mean_responses: dict[str, float]) -> float:
        """Eq. 3.3 (unit weights) of replicate-mean responses."""
        return float(sum(self.squared_errors(mean_responses)))

    def true_objective(self, x) -> float:
        return self.objective(self.response_values(x))

    def worst_miss_in_spreads(self, x) -> float:
        """The largest |y - r| / s over the responses at x: noise-free y, s the target's
        measurement spread."""
        clean, targets, spreads = self.response_values(x), self.targets, self.spreads
        return max(abs(clean[k] - targets[k]) / spreads[k] for k in self.keys)

    def noisy_responses(self, x, seed: int, k: int) -> dict[str, list[float]]:
        """The replicate values of each response of evaluation ``k`` (0-based) of run ``seed``."""
        rng = np.random.default_rng([NOISE_KEY, zlib.crc32(self.name.encode()), int(seed), int(k)])
        draws = rng.standard_normal((self.replicates, len(self.responses)))
        clean, sd = self.response_values(x), self.noise_sd
        return {
            key: [clean[key] + sd[key] * float(draws[i, j]) for i in range(self.replicates)]
            for j, key in enumerate(self.keys)
        }


def mean_responses(responses: dict[str, list[float]]) -> dict[str, float]:
    return {key: float(np.mean(values)) for key, values in responses.items()}


class Evaluator:
    """The simulations of one run: noisy responses of evaluation k, objective, log, time inside.

    Calling it with x returns ``(responses, objective, replicate_objectives)``:
    ``responses`` = {key: [replicate values]}, ``objective`` = eq. 3.3 of
    the replicate means (what the tools minimise), ``replicate_objectives`` =
    eq. 3.3 of each replicate index alone ([] with one replicate).
    """

    def __init__(self, problem: Problem, seed: int):
        self.problem = problem
        self.seed = seed
        self.log: list[dict] = []  # x, objective (noisy)
        self.seconds = 0.0

    def __call__(self, x):
        start = time.perf_counter()
        x = [float(v) for v in x]
        responses = self.problem.noisy_responses(x, self.seed, len(self.log))
        value = self.problem.objective(mean_responses(responses))
        per_replicate = []
        if self.problem.replicates > 1:
            per_replicate = [
                self.problem.objective({key: responses[key][i] for key in responses})
                for i in range(self.problem.replicates)
            ]
        self.log.append({"x": x, "objective": value})
        self.seconds += time.perf_counter() - start
        return responses, value, per_replicate


# ------------------------------------------------------------------ models
# u = saturating(sliding friction, 0.3), v = saturating(rolling friction, 0.1):
# the angle of repose rises with both and levels off, the packing (bulk
# density / particle density) falls with both, the hopper's mass flow falls
# with the frictions (Beverloo-like volume rate times bulk density).


def _p3r3(x):
    sliding, rolling, density = x
    u, v = saturating(sliding, 0.3), saturating(rolling, 0.1)
    angle = 10.0 + 14.0 * u + 16.0 * v + 6.0 * u * v  # deg
    packing = 0.62 - 0.06 * u - 0.03 * v
    bulk_density = density * packing  # kg/m^3
    mass_flow = bulk_density * 3.6e-5 * (1.25 - 0.5 * u - 0.15 * v)  # kg/s
    return angle, bulk_density, mass_flow


def _p5r2(x):
    density, sliding_pp, sliding_pw, rolling_pp, rolling_pw = x
    u_pp, u_pw = saturating(sliding_pp, 0.3), saturating(sliding_pw, 0.3)
    v_pp, v_pw = saturating(rolling_pp, 0.1), saturating(rolling_pw, 0.1)
    angle = 10.0 + 13.0 * u_pp + 15.0 * v_pp + 5.0 * u_pp * v_pp + 3.0 * u_pw + 2.0 * v_pw
    packing = 0.625 - 0.055 * u_pp - 0.03 * v_pp - 0.012 * u_pw - 0.006 * v_pw
    return angle, density * packing


def _p2r2rep(x):
    sliding_pp, sliding_pw = x
    u_pp, u_pw = saturating(sliding_pp, 0.3), saturating(sliding_pw, 0.3)
    mass_flow = 0.104 * (1.0 - 0.35 * u_pp - 0.30 * u_pw)  # kg/s
    angle = 2.0 + 9.0 * u_pp + 2.5 * u_pw  # deg
    return mass_flow, angle


ANGLE = "cylinder_lift.angle_of_repose"
BULK = "cylinder_lift.bulk_density"

PROBLEMS = {
    p.name: p
    for p in (
        Problem(
            "p3r3",
            "3 parameters / 3 responses, identifiable: sliding and rolling friction and particle "
            "density against angle of repose and bulk density (cylinder lift) and hopper mass flow",
            ("sliding_friction", "rolling_friction", "particle_density"),
            (0.1, 0.02, 2000.0),
            (0.9, 0.3, 3000.0),
            (0.42, 0.075, 2650.0),
            (
                Response(ANGLE, "deg", 0.06, 0.05),
                Response(BULK, "kg/m^3", 0.003, 0.005),
                Response("hopper.mass_flow", "kg/s", 0.02, 0.02),
            ),
            _p3r3,
        ),
        Problem(
            "p5r2",
            "5 parameters / 2 responses, non-unique (a 3-D manifold of solutions): particle "
            "density, sliding and rolling friction particle-particle and particle-wall against "
            "angle of repose and bulk density (cylinder lift, as in Rackl & Hanley 2017)",
            (
                "particle_density",
                "sliding_friction_pp",
                "sliding_friction_pw",
                "rolling_friction_pp",
                "rolling_friction_pw",
            ),
            (2000.0, 0.1, 0.1, 0.02, 0.02),
            (3000.0, 0.9, 0.9, 0.3, 0.3),
            (2600.0, 0.5, 0.35, 0.12, 0.08),
            (
                Response(ANGLE, "deg", 0.06, 0.05),
                Response(BULK, "kg/m^3", 0.003, 0.005),
            ),
            _p5r2,
        ),
        Problem(
            "p2r2rep",
            "2 parameters / 2 responses, 2 replicates per evaluation: sliding friction "
            "particle-particle and particle-wall against mass flow and angle of repose "
            "(calibration device)",
            ("sliding_friction_pp", "sliding_friction_pw"),
            (0.2, 0.2),
            (0.9, 0.9),
            (0.45, 0.35),
            (
                Response("calibration_device.mass_flow", "kg/s", 0.02, 0.02),
                Response("calibration_device.angle_of_repose", "deg", 0.07, 0.05),
            ),
            _p2r2rep,
            replicates=2,
        ),
    )
}
