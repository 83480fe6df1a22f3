"""The solution space of a calibration and what the targets identify.

A DEM calibration is often not unique: several parameter sets reproduce the
measured bulk responses equally well (Rackl & Hanley 2017, sec. 3.1, found
a whole family for the cylinder lift; Richter & Will 2021, sec. 4.2, read
the non-uniqueness off their per-response metamodels). demcal answers the
question on the optimizer's response models:

* :func:`sample_solutions` — the parameter sets whose predicted responses
  all lie within ``k`` combined standard deviations of the targets (target
  spread, simulation noise and the model's own standard deviation), found
  by dense scrambled-Sobol sampling of the box;
* :func:`identifiability` — per parameter, the range it spans inside that
  set and a verdict in words (pinned, partly identified, not identified);
* :func:`sensitivity_indices` — first-order and total Sobol indices of
  each response on its model (Saltelli sampling, SALib), which says whether
  a parameter that is not identified moves no response at all or trades
  off against the others.

Pure functions of a :class:`~demcal.optimizer.responses.ResponsePredictor`
and the bounds; the files and figures are in :mod:`demcal.analysis.solution_report`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.stats import qmc

from demcal.optimizer.responses import ResponsePredictor
from demcal.study.objective import Target

#: Width of the central share of the solution set, relative to the bounds, at or below which a
#: parameter counts as pinned, and above which it counts as not identified.
PINNED_SHARE, NOT_IDENTIFIED_SHARE = 0.25, 0.6
#: A parameter whose largest total Sobol index over the responses is below this moves no response.
INSENSITIVE_INDEX = 0.05
#: Fewer accepted samples than this give no verdict.
MIN_SOLUTIONS = 20
#: Prediction batch size (memory of the Kriging predictions).
BATCH = 8192


def simulation_noise_sd(
    predictor: ResponsePredictor, observed: dict[str, tuple[np.ndarray, np.ndarray]]
) -> dict[str, float]:
    """Scatter of the simulated responses about their models: RMS of observed − predicted.

    ``observed``: per response, the evaluated points (unit box) and the
    simulated means there.
    """
    noise = {}
    for key, model in predictor.models.items():
        x, y = observed[key]
        noise[key] = float(np.sqrt(np.mean((y - model.predict(x)) ** 2))) if len(y) else 0.0
    return noise


def tolerance_sd(target: Target, noise_sd: float, model_sd: np.ndarray) -> np.ndarray:
    """The combined standard deviation a prediction may miss its target by, per point.

    sqrt(spread² + noise² + model sd²): the measurement spread of the target,
    the scatter of single simulations, and the model's uncertainty there.
    """
    spread = target.spread or 0.0
    return np.sqrt(spread**2 + noise_sd**2 + np.asarray(model_sd) ** 2)


def within_tolerance(
    targets: tuple[Target, ...],
    means: dict[str, np.ndarray],
    stds: dict[str, np.ndarray],
    noise_sd: dict[str, float],
    k: float,
) -> np.ndarray:
    """Whether every targeted response is within ``k`` combined sd of its target (per point)."""
    accepted = None
    for t in targets:
        ok = np.abs(means[t.key] - t.value) <= k * tolerance_sd(t, noise_sd[t.key], stds[t.key])
        accepted = ok if accepted is None else accepted & ok
    return accepted


@dataclass(frozen=True)
class SolutionSet:
    """Accepted points of the box (unit coordinates) with their predicted responses.

    ``supported``: per accepted point, whether every model is surer there
    than the target spread and simulation noise combined, i.e. the point is
    accepted on the simulations' evidence and not only because the models
    cannot rule it out (an unexplored region).
    """

    points_unit: np.ndarray
    means: dict[str, np.ndarray]
    stds: dict[str, np.ndarray]
    sampled: int
    k: float
    noise_sd: dict[str, float]
    supported: np.ndarray


def sample_solutions(
    predictor: ResponsePredictor,
    dimension: int,
    noise_sd: dict[str, float],
    k: float = 2.0,
    samples: int = 2**16,
    seed: int = 0,
) -> SolutionSet:
    """The points of a scrambled Sobol sample of the unit box that meet every
    target within ``k`` sd."""
    sampler = qmc.Sobol(dimension, scramble=True, seed=seed)
    points = sampler.random_base2(int(math.ceil(math.log2(samples))))
    kept, means, stds = (
        [],
        {key: [] for key in predictor.models},
        {key: [] for key in predictor.models},
    )
    for start in range(0, len(points), BATCH):
        batch = points[start : start + BATCH]
        mean, std = predictor.predict(batch)
        ok = within_tolerance(predictor.objective.targets, mean, std, noise_sd, k)
        kept.append(batch[ok])
        for key in predictor.models:
            means[key].append(mean[key][ok])
            stds[key].append(std[key][ok])
    stds = {key: np.concatenate(v) for key, v in stds.items()}
    supported = np.ones(sum(len(batch) for batch in kept), bool)
    for t in predictor.objective.targets:
        supported &= stds[t.key] <= tolerance_sd(t, noise_sd[t.key], 0.0)
    return SolutionSet(
        np.vstack(kept),
        {key: np.concatenate(v) for key, v in means.items()},
        stds,
        len(points),
        k,
        noise_sd,
        supported,
    )


@dataclass(frozen=True)
class Verdict:
    """What the targets say about one parameter."""

    name: str
    unit: str
    lower: float  # bounds
    upper: float
    low: float  # the central 95 % of the solution set (NaN without a set)
    high: float
    share: float  # (high - low) / (upper - lower)
    verdict: str  # "pinned", "partly identified", "not identified", "no solutions"
    sentence: str


def _fmt(value: float) -> str:
    return f"{value:.3g}"


def identifiability(
    solutions: SolutionSet,
    names: list[str],
    units: list[str],
    lower: np.ndarray,
    upper: np.ndarray,
    total_index: dict[str, float] | None = None,
) -> list[Verdict]:
    """A verdict per parameter from the span of the solution set (central 95 %).

    The span is taken over the points the simulations support (``supported``)
    when there are enough of them, so that a region the calibration never
    explored does not pass for a solution; the sentence then says how much
    of the set lies where the models are unsure. ``total_index``: per
    parameter, its largest total Sobol index over the responses; it tells a
    parameter no response moves from one that trades off against the others.
    """
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    verdicts = []
    points = solutions.points_unit
    unsure = 1.0 - float(np.mean(solutions.supported)) if len(points) else 0.0
    if int(np.sum(solutions.supported)) >= MIN_SOLUTIONS and unsure > 0.0:
        points = points[solutions.supported]
        caveat = (
            f" (over the {len(points)} sets the simulations support; the other {100 * unsure:.0f} "
            "% of the set lie where the models are unsure, too little explored to rule out)"
        )
    else:
        caveat = ""
    count = len(points)
    for i, (name, unit) in enumerate(zip(names, units)):
        box = f"{_fmt(lower[i])}–{_fmt(upper[i])}" + ("" if unit in ("-", "") else f" {unit}")
        if count < MIN_SOLUTIONS:
            sentence = (
                f"{name}: no verdict: only {count} of {solutions.sampled} sampled parameter sets "
                f"meet all targets within {solutions.k:g} sd (the targets may lie outside what "
                "these bounds reach)"
            )
            verdicts.append(
                Verdict(
                    name,
                    unit,
                    lower[i],
                    upper[i],
                    math.nan,
                    math.nan,
                    math.nan,
                    "no solutions",
                    sentence,
                )
            )
            continue
        low_u, high_u = np.percentile(points[:, i], [2.5, 97.5])
        low, high = (
            lower[i] + low_u * (upper[i] - lower[i]),
            lower[i] + high_u * (upper[i] - lower[i]),
        )
        share = float(high_u - low_u)
        spans = f"it spans {_fmt(low)}–{_fmt(high)} of {box} ({100 * share:.0f} %){caveat}"
        if share <= PINNED_SHARE:
            verdict, sentence = "pinned", f"{name}: pinned by these targets: {spans}"
        elif share <= NOT_IDENTIFIED_SHARE:
            verdict, sentence = "partly identified", f"{name}: partly identified: {spans}"
        else:
            verdict = "not identified"
            index = None if total_index is None else total_index.get(name)
            if index is not None and index < INSENSITIVE_INDEX:
                why = (
                    "no targeted response is sensitive to it (total Sobol index at most "
                    f"{index:.2f}); a test sensitive to {name} would pin it"
                )
            else:
                why = (
                    "it trades off against other parameters (several combinations match the "
                    f"targets equally well); one more test sensitive to {name} would pin it"
                )
            sentence = f"{name}: not identified by these targets: {spans}; {why}"
        verdicts.append(
            Verdict(name, unit, lower[i], upper[i], low, high, share, verdict, sentence)
        )
    return verdicts


def sensitivity_indices(
    predictor: ResponsePredictor, names: list[str], base_samples: int = 1024, seed: int = 0
) -> list[dict]:
    """First-order (S1) and total (ST) Sobol indices of each response's model over the box.

    Saltelli's sampling and estimators (SALib); the model's predicted mean
    stands in for the simulation. One row per (response, parameter).
    """
    from SALib.analyze import sobol as sobol_analyze
    from SALib.sample import sobol as sobol_sample

    problem = {"num_vars": len(names), "names": list(names), "bounds": [[0.0, 1.0]] * len(names)}
    x = sobol_sample.sample(problem, base_samples, calc_second_order=False, seed=seed)
    means, _ = predictor.predict(x)
    rows = []
    for key, y in means.items():
        if np.ptp(y) == 0.0:
            indices = {"S1": np.zeros(len(names)), "ST": np.zeros(len(names))}
        else:
            indices = sobol_analyze.analyze(
                problem,
                np.asarray(y, float),
                calc_second_order=False,
                print_to_console=False,
                seed=seed,
            )
        for i, name in enumerate(names):
            rows.append(
                {
                    "response": key,
                    "parameter": name,
                    "S1": float(indices["S1"][i]),
                    "ST": float(indices["ST"][i]),
                }
            )
    return rows


def largest_total_index(rows: list[dict]) -> dict[str, float]:
    """Per parameter, its largest total Sobol index over the responses."""
    largest: dict[str, float] = {}
    for row in rows:
        largest[row["parameter"]] = max(largest.get(row["parameter"], 0.0), row["ST"])
    return largest
