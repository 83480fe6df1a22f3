"""Analytic test engine: closed-form responses with seeded noise and a fake duration.

Its driver is the scene's closed-form model, ``model(parameters, settings)
-> {response: value}``. It behaves like a real engine on disk (progress and
early estimates in partial.csv, STOP honoured between chunks, failures with
reasons) so the whole pipeline and the optimizer can be tested in seconds.
Engine settings:

- ``noise``: relative standard deviation of every response (default 0.01),
  or a mapping response -> relative standard deviation;
- ``duration``: simulated wall time of one run [s] (default 0), spent in
  ``chunks`` equal chunks (default 10);
- ``failures``: list of ``{"when": {parameter: [low, high], ...},
  "mode": "always" | "once", "reason": text}``: a run whose parameters lie in
  every given interval fails, always or only on an evaluation's first attempt;
- ``cpu``: CPU seconds a run reports as its cost (default: its ``duration``).

A cheaper fidelity level of a study changes the engine's settings
(``fidelities.<level>.engine``), and these distort the closed-form model as a coarse
simulation's known bias would (`distorted`): ``scale`` and ``bias`` (a number, or per
response; default 1 and 0) make a response ``scale * exact + bias``, the multi-fidelity
model's assumption (Kennedy & O'Hagan 2000); ``ripple`` (relative amplitude, per response)
adds a term that oscillates across the parameter box, which the fine level does not have,
so that a level can be poorly correlated with the fine one on purpose.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from demcal.engines.base import DeclaredScene, Engine, RunMonitor, RunResult, SimulationJob
from demcal.errors import ConfigError
from demcal.physics.catalogue import CATALOG
from demcal.results.records import Status

#: The analytic engine's driver, a scene's closed-form model: (parameters, settings) ->
#: {response: value}.
AnalyticModel = Callable[[dict[str, float], dict[str, Any]], dict[str, float]]


def _injected_failure(
    failures: list[dict[str, Any]], parameters: dict[str, float]
) -> dict[str, Any] | None:
    """The first failure rule whose intervals all contain the parameters, or None."""
    for rule in failures:
        if all(low <= parameters[name] <= high for name, (low, high) in rule["when"].items()):
            return rule
    return None


#: Oscillations of the ``ripple`` term across each parameter's catalogue range.
RIPPLE_PERIODS = 3.0


def _per_response(value: float | dict[str, float], response: str, unset: float) -> float:
    """A setting given as one number for every response or per response (``unset`` where a
    mapping leaves the response out)."""
    return value.get(response, unset) if isinstance(value, dict) else value


def ripple_phase(parameters: dict[str, float]) -> float:
    """The phase [rad] of the ``ripple`` term: RIPPLE_PERIODS turns across the catalogue range
    of every parameter with a finite one, summed, so it varies with each free parameter."""
    phase = 0.0
    for name, value in parameters.items():
        spec = CATALOG.get(name)
        if spec is not None and math.isfinite(spec.upper - spec.lower) and spec.upper > spec.lower:
            phase += (value - spec.lower) / (spec.upper - spec.lower)
    return 2.0 * math.pi * RIPPLE_PERIODS * phase


def distorted(
    exact: dict[str, float], parameters: dict[str, float], settings: dict[str, Any]
) -> dict[str, float]:
    """The closed-form responses as a level with the engine ``settings`` gives them:
    ``scale * exact + bias + ripple * |exact| * sin(ripple_phase)`` per response."""
    phase = ripple_phase(parameters)
    return {
        name: _per_response(settings.get("scale", 1.0), name, 1.0) * value
        + _per_response(settings.get("bias", 0.0), name, 0.0)
        + _per_response(settings.get("ripple", 0.0), name, 0.0) * abs(value) * math.sin(phase)
        for name, value in exact.items()
    }


def noisy_responses(
    model: AnalyticModel,
    parameters: dict[str, float],
    settings: dict[str, Any],
    engine_settings: dict[str, Any],
    seed: int,
) -> dict[str, float]:
    """The closed-form model's responses at the engine's level (`distorted`), each times
    (1 + N(0, noise^2)), seeded."""
    exact = distorted(model(parameters, settings), parameters, engine_settings)
    noise = engine_settings.get("noise", 0.01)
    rng = np.random.default_rng(seed)
    out = {}
    for name in sorted(exact):
        sd = noise.get(name, 0.0) if isinstance(noise, dict) else noise
        out[name] = exact[name] * (1.0 + sd * rng.standard_normal())
    return out


class AnalyticEngine(Engine):
    name = "analytic"
    #: the fake run time, its chunks and the injected failures leave an ok run's responses be
    INERT_SETTINGS = ("timeout", "duration", "chunks", "failures")
    steps_in_time = False

    def check(self, scenes: Sequence[DeclaredScene]) -> None:
        for i, rule in enumerate(self.settings.get("failures", [])):
            for name in rule.get("when", {}):
                if not any(name in s.parameters for s in scenes):
                    raise ConfigError(
                        f"engine.failures[{i}].when.{name}: not a parameter of the study's scenes"
                    )

    def version(self) -> str:
        return "analytic-1"

    def run(
        self, job: SimulationJob, monitor: RunMonitor, driver: AnalyticModel | None
    ) -> RunResult:
        if driver is None:
            return RunResult(
                Status.FAILED, f"analytic engine has no driver for scene {job.scene!r}"
            )
        start_wall = time.monotonic()
        chunks = int(self.settings.get("chunks", 10))
        duration = float(self.settings.get("duration", 0.0))
        failure = _injected_failure(self.settings.get("failures", []), job.parameters)
        responses = noisy_responses(driver, job.parameters, job.settings, self.settings, job.seed)
        cpu = self.settings.get("cpu")

        def cost(steps: int) -> dict[str, float]:
            share = steps / chunks
            return {
                "wall_s": time.monotonic() - start_wall,
                "cpu_s": share * (duration if cpu is None else float(cpu)),
                "steps": steps,
            }

        for chunk in range(1, chunks + 1):
            if monitor.stop_requested():
                return RunResult(Status.TERMINATED, "stop requested", cost=cost(chunk - 1))
            time.sleep(duration / chunks)
            progress = chunk / chunks
            if (
                failure is not None
                and progress >= 0.5
                and (failure.get("mode", "always") == "always" or job.attempt == 0)
            ):
                return RunResult(
                    Status.FAILED, failure.get("reason", "injected failure"), cost=cost(chunk)
                )
            # from half way on, the responses are known: final values, flagged so
            early = {r: responses[r] for r in job.responses} if progress >= 0.5 else None
            monitor.progress(progress, "run", early, final=early is not None)
        return RunResult(
            Status.OK, measurements={r: responses[r] for r in job.responses}, cost=cost(chunks)
        )
