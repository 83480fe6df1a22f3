"""The solution space of a calibration and what the targets identify.

A DEM calibration is often not unique: several parameter sets reproduce the
measured bulk responses equally well (Rackl & Hanley 2017, sec. 3.1, found
a whole family for the cylinder lift; Richter & Will 2021, sec. 4.2, read
the non-uniqueness off their per-response metamodels). demcal answers the
question on the optimizer's response models:

* `membership_probability` — per point, the probability that every
  noise-free response lies within ``k`` combined standard deviations (target
  spread and simulation noise) of its target, under the models' posteriors;
* `sample_solutions` — the points of a dense scrambled-Sobol sample of
  the box that the models cannot rule out, with that probability: the
  likely set (at least as likely in as out) and the part still undecided;
* `identifiability` — per parameter, its span over the whole likely
  set and a verdict in words (pinned, partly identified, not identified),
  or "not established yet" where the undecided part could widen the span;
* `sensitivity_indices` — first-order and total Sobol indices of
  each response on its model (Saltelli sampling, SALib), which says whether
  a parameter that is not identified moves no response at all or trades
  off against the others.

Pure functions of a `ResponsePredictor`
and the bounds; the files and figures are in `demcal.analysis.solution_report`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.stats import qmc

from demcal.optimizer.bounds import from_unit_box
from demcal.optimizer.membership import (
    BAND_SD,
    LIKELY,
    POSSIBLE,
    SURE,
    membership_probability,
    tolerance_sd,
)
from demcal.optimizer.objective import Target
from demcal.optimizer.responses import ResponsePredictor

#: Width of a parameter's span over the solution set, relative to the bounds, at or below which
#: it counts as pinned, and above which it counts as not identified.
PINNED_SHARE, NOT_IDENTIFIED_SHARE = 0.25, 0.6
#: How far (share of the bounds) the possible set may reach beyond the likely one at either end
#: for a span to count as established.
ESTABLISHED_MARGIN = 0.05
#: A parameter whose largest total Sobol index over the responses is below this moves no response.
INSENSITIVE_INDEX = 0.05
#: Where a verdict says that one more test would pin a parameter: the command that says which.
ADVISE_HINT = "demcal advise STUDY.yaml ranks demcal's lab tests by how far each would narrow it"
#: Fewer accepted samples than this give no verdict.
MIN_SOLUTIONS = 20
#: A solution set with fewer likely points than this is sampled again, densely, around itself.
THIN_SET = 300
#: The fewest and most Sobol points a solution analysis samples over the box (a million
#: points of a 2-parameter study take about 10 s and 300 MB).
SOLUTION_SAMPLES = (64, 2**20)
#: Prediction batch size (memory of the Kriging predictions).
BATCH = 8192


def simulation_noise_sd(
    predictor: ResponsePredictor,
    observed: dict[str, tuple[np.ndarray, np.ndarray]],
    replicate_variance: dict[str, float] | None = None,
) -> dict[str, float]:
    """The scatter of single simulations per response: the largest of three estimates.

    The RMS of observed − predicted (``observed``: per response, the
    evaluated points in the unit box and the simulated means there), the
    noise the model's fit attributes to the data (a Kriging nugget), and
    the scatter measured between replicates (``replicate_variance``).
    """
    noise = {}
    for key, model in predictor.models.items():
        x, y = observed[key]
        residual = float(np.sqrt(np.mean((y - model.predict(x)) ** 2))) if len(y) else 0.0
        replicates = math.sqrt((replicate_variance or {}).get(key, 0.0))
        noise[key] = max(residual, model.noise_sd, replicates)
    return noise


def membership_word(probability: float) -> str:
    """What a membership probability says of one parameter set, in the report's words."""
    if probability >= SURE:
        return "in the solution set"
    if probability >= LIKELY:
        return "likely in the solution set"
    if probability >= POSSIBLE:
        return "undecided: the models cannot rule it out"
    return "ruled out"


def log_likelihood(
    targets: tuple[Target, ...],
    means: dict[str, np.ndarray],
    stds: dict[str, np.ndarray],
    noise_sd: dict[str, float],
) -> np.ndarray:
    """The log-likelihood of the targets per point: each target normal about the model's
    prediction with variance spread² + noise² + model sd² (independent responses), up to a
    constant."""
    total = np.zeros(len(next(iter(means.values()))))
    for t in targets:
        variance = tolerance_sd(t, noise_sd[t.key], stds[t.key]) ** 2
        variance = np.maximum(variance, np.finfo(float).tiny)
        miss = means[t.key] - t.nearest(means[t.key])  # 0 inside a target's bounds
        total -= 0.5 * (miss**2 / variance + np.log(variance))
    return total


@dataclass(frozen=True)
class Posterior:
    """The posterior of the parameters with a uniform prior over the box and the targets'
    Gaussian likelihood (`log_likelihood`), from the weighted Sobol sample.

    ``low`` and ``high``: each parameter's central 90 % interval (unit box);
    ``correlation``: the parameters' correlation matrix; ``effective_samples``:
    Kish's effective sample size of the weights (few: the interval is rough);
    ``points_unit`` and ``weights``: the sample itself, every Sobol point of the
    box (unit coordinates) with its importance weight (its likelihood, the
    weights summing to 1).
    """

    low: np.ndarray
    high: np.ndarray
    correlation: np.ndarray
    effective_samples: float
    points_unit: np.ndarray
    weights: np.ndarray


def weighted_quantile(values: np.ndarray, weights: np.ndarray, q: float) -> float:
    """The ``q`` quantile of ``values`` under normalised ``weights``."""
    order = np.argsort(values)
    cumulative = np.cumsum(weights[order])
    return float(values[order][min(int(np.searchsorted(cumulative, q)), len(values) - 1)])


def posterior_of(points: np.ndarray, log_weights: np.ndarray) -> Posterior:
    """The posterior of weighted ``points``: their 90 % intervals, correlation and effective
    sample size, and the points with their normalised weights."""
    weights = np.exp(log_weights - log_weights.max())
    weights /= weights.sum()
    mean = weights @ points
    centred = points - mean
    covariance = (weights[:, None] * centred).T @ centred
    sd = np.sqrt(np.maximum(np.diag(covariance), np.finfo(float).tiny))
    return Posterior(
        np.array([weighted_quantile(points[:, i], weights, 0.05) for i in range(len(mean))]),
        np.array([weighted_quantile(points[:, i], weights, 0.95) for i in range(len(mean))]),
        covariance / np.outer(sd, sd),
        float(1.0 / np.sum(weights**2)),
        points,
        weights,
    )


@dataclass(frozen=True)
class SolutionSet:
    """The points of the box (unit coordinates) that may meet every target, with their predicted
    responses and membership probability (`membership_probability`).

    Every point kept has a probability of at least ``POSSIBLE``: the models
    cannot rule it out. ``likely`` marks those at least as likely in as out
    (the estimate of the set); ``unsure`` those whose membership the models
    cannot yet decide (below ``SURE``): where no simulation has been.
    """

    points_unit: np.ndarray
    means: dict[str, np.ndarray]
    stds: dict[str, np.ndarray]
    probability: np.ndarray
    sampled: int
    k: float
    noise_sd: dict[str, float]
    posterior: Posterior

    @property
    def likely(self) -> np.ndarray:
        return self.probability >= LIKELY

    @property
    def unsure(self) -> np.ndarray:
        return self.probability < SURE

    @property
    def unsure_share(self) -> float:
        """The share of the possible set whose membership is not decided yet."""
        return float(np.mean(self.unsure)) if len(self.probability) else 0.0


def _scan(
    predictor: ResponsePredictor, points: np.ndarray, noise_sd: dict[str, float], k: float
) -> tuple[np.ndarray, dict[str, np.ndarray], dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """The ``points`` the models cannot rule out, their predicted means, sds and membership
    probabilities, and the log-likelihood of every one of ``points``; in batches."""
    kept, probabilities, log_weights = [], [], []
    means: dict[str, list[np.ndarray]] = {key: [] for key in predictor.models}
    stds: dict[str, list[np.ndarray]] = {key: [] for key in predictor.models}
    for start in range(0, len(points), BATCH):
        batch = points[start : start + BATCH]
        mean, std = predictor.predict(batch)
        probability = membership_probability(predictor.objective.targets, mean, std, noise_sd, k)
        log_weights.append(log_likelihood(predictor.objective.targets, mean, std, noise_sd))
        possible = probability >= POSSIBLE
        kept.append(batch[possible])
        probabilities.append(probability[possible])
        for key in predictor.models:
            means[key].append(mean[key][possible])
            stds[key].append(std[key][possible])
    return (
        np.vstack(kept),
        {key: np.concatenate(v) for key, v in means.items()},
        {key: np.concatenate(v) for key, v in stds.items()},
        np.concatenate(probabilities),
        np.concatenate(log_weights),
    )


def sample_solutions(
    predictor: ResponsePredictor,
    dimension: int,
    noise_sd: dict[str, float],
    k: float = BAND_SD,
    samples: int = 2**16,
    seed: int = 0,
) -> SolutionSet:
    """The points of a scrambled Sobol sample of the unit box that the models cannot rule out.

    A thin set (fewer than ``THIN_SET`` likely points) is sampled again as
    densely within the box around the possible points, widened by two
    sample spacings, so that its ends are found to a finer resolution. The
    posterior comes from the first, uniform sample.
    """
    sampler = qmc.Sobol(dimension, scramble=True, seed=seed)
    points = sampler.random_base2(int(math.ceil(math.log2(samples))))
    kept, means, stds, probability, log_weights = _scan(predictor, points, noise_sd, k)
    posterior = posterior_of(points, log_weights)
    if len(kept) and np.sum(probability >= LIKELY) < THIN_SET:
        margin = 2.0 * len(points) ** (-1.0 / dimension)
        low = np.clip(kept.min(axis=0) - margin, 0.0, 1.0)
        high = np.clip(kept.max(axis=0) + margin, 0.0, 1.0)
        dense = low + qmc.Sobol(dimension, scramble=True, seed=seed + 1).random_base2(
            int(math.ceil(math.log2(samples)))
        ) * (high - low)
        kept, means, stds, probability, _ = _scan(predictor, dense, noise_sd, k)
    return SolutionSet(kept, means, stds, probability, len(points), k, noise_sd, posterior)


@dataclass(frozen=True)
class Verdict:
    """What the targets say about one parameter.

    ``low``–``high``: its span over the likely set (NaN without one);
    ``possible_low``–``possible_high``: over every set the models cannot
    rule out, which exploring may still confirm; ``share``: the likely
    span as a share of the bounds; ``verdict``: pinned, partly identified,
    not identified, not established or no solutions;
    ``posterior_low``–``posterior_high``: the central 90 % of its posterior
    (`Posterior`), for comparison.
    """

    name: str
    unit: str
    lower: float  # bounds
    upper: float
    low: float
    high: float
    possible_low: float
    possible_high: float
    share: float
    verdict: str
    sentence: str
    posterior_low: float
    posterior_high: float


def _fmt(value: float) -> str:
    return f"{value:.3g}"


def _span(points: np.ndarray, i: int, lower: float, upper: float) -> tuple[float, float]:
    """The full span of column ``i`` of unit ``points`` in real units (NaN without points)."""
    if not len(points):
        return math.nan, math.nan
    low_u, high_u = float(points[:, i].min()), float(points[:, i].max())
    low, high = from_unit_box([low_u, high_u], lower, upper)
    return float(low), float(high)


def identifiability(
    solutions: SolutionSet,
    names: list[str],
    units: list[str],
    lower: np.ndarray,
    upper: np.ndarray,
    total_index: dict[str, float] | None = None,
    explore_command: str = "demcal solutions --explore 8 STUDY",
) -> list[Verdict]:
    """A verdict per parameter from its span over the whole likely set.

    A verdict of "pinned" or "partly identified" is given only when the
    sets the models cannot rule out reach no further (within
    ``ESTABLISHED_MARGIN`` of the box) than the likely set: exploring could
    not widen the span. Otherwise it is "not established", with the share
    of the set still undecided and ``explore_command``. A likely span wider
    than ``NOT_IDENTIFIED_SHARE`` is "not identified" either way: exploring
    can only widen it. ``total_index``: per parameter, its largest total
    Sobol index over the responses; it tells a parameter no response moves
    from one that trades off against the others.
    """
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    possible = solutions.points_unit
    likely = possible[solutions.likely]
    undecided = f"{100 * solutions.unsure_share:.0f} %"
    verdicts = []
    for i, (name, unit) in enumerate(zip(names, units)):
        box = f"{_fmt(lower[i])}–{_fmt(upper[i])}" + ("" if unit in ("-", "") else f" {unit}")
        low, high = _span(likely, i, lower[i], upper[i])
        possible_low, possible_high = _span(possible, i, lower[i], upper[i])
        width = upper[i] - lower[i]
        share = (high - low) / width if len(likely) else math.nan
        reach = f"it could reach {_fmt(possible_low)}–{_fmt(possible_high)} of {box}"
        if len(possible) < MIN_SOLUTIONS:
            verdict = "no solutions"
            sentence = (
                f"{name}: no verdict: only {len(possible)} of {solutions.sampled} sampled "
                f"parameter sets may meet all targets within {solutions.k:g} sd (the targets may "
                "lie outside what these bounds reach, or be too narrow for a set of any width: "
                "give each target the spread of its measurement)"
            )
        elif len(likely) < MIN_SOLUTIONS:
            verdict = "not established"
            sentence = (
                f"{name}: not established yet: no parameter set is yet predicted to meet every "
                f"target; {reach}, where no simulation has been; `{explore_command}` simulates "
                "there"
            )
        else:
            spans = f"it spans {_fmt(low)}–{_fmt(high)} of {box} ({100 * share:.0f} %)"
            widens = max(low - possible_low, possible_high - high) > ESTABLISHED_MARGIN * width
            if share > NOT_IDENTIFIED_SHARE:
                verdict = "not identified"
                sentence = f"{name}: not identified by these targets: {spans}; " + _why(
                    name, total_index
                )
            elif widens:
                verdict = "not established"
                sentence = (
                    f"{name}: not established yet: {spans}, but {reach}: {undecided} of the set "
                    f"lies where no simulation has been; `{explore_command}` simulates there"
                )
            elif share <= PINNED_SHARE:
                verdict, sentence = "pinned", f"{name}: pinned by these targets: {spans}"
            else:
                verdict, sentence = "partly identified", f"{name}: partly identified: {spans}"
        verdicts.append(
            Verdict(
                name,
                unit,
                lower[i],
                upper[i],
                low,
                high,
                possible_low,
                possible_high,
                share,
                verdict,
                sentence,
                lower[i] + solutions.posterior.low[i] * width,
                lower[i] + solutions.posterior.high[i] * width,
            )
        )
    return verdicts


def _why(name: str, total_index: dict[str, float] | None) -> str:
    """Why a parameter is not identified: no response moves it, or it trades off."""
    index = None if total_index is None else total_index.get(name)
    if index is not None and index < INSENSITIVE_INDEX:
        return (
            f"no targeted response is sensitive to it (total Sobol index at most {index:.2f}); "
            f"a test sensitive to {name} would pin it ({ADVISE_HINT})"
        )
    return (
        "it trades off against other parameters (several combinations match the targets equally "
        f"well); one more test sensitive to {name} would pin it ({ADVISE_HINT})"
    )


def sensitivity_indices(
    predictor: ResponsePredictor, names: list[str], base_samples: int = 1024, seed: int = 0
) -> list[dict[str, Any]]:
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


def largest_total_index(rows: list[dict[str, Any]]) -> dict[str, float]:
    """Per parameter, its largest total Sobol index over the responses."""
    largest: dict[str, float] = {}
    for row in rows:
        largest[row["parameter"]] = max(largest.get(row["parameter"], 0.0), row["ST"])
    return largest
