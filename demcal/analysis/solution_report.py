"""The solution space of a study on disk: analysis from optimizer.json, tables and figures.

``demcal solutions CONFIG`` and the report's ``solutions`` job call
`write_solutions`. It rebuilds the response models from the
optimizer's saved evaluations (the same models the optimizer used), applies
`demcal.analysis.solutions` and writes:

- ``results/<study>/solutions.csv``: the accepted parameter sets with their
  predicted responses and standard deviations;
- ``results/<study>/solutions.json``: tolerances, counts and the verdict per
  parameter;
- ``plots/solution_space.png``: corner plot of the set (pairwise scatter,
  histograms, bounds as axis limits, the best point);
- ``plots/sensitivity.png`` and ``plots/sensitivity.csv``: Sobol indices of
  each response per parameter;
- ``plots/objective_slices.png``: contours of the predicted objective over
  pairs of the most influential parameters through the best point.

The ``plot_*`` functions return their figure and, given a ``path``, write it
there (as ``demcal.reporting.figures`` does).
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from demcal.analysis.solutions import (
    SolutionSet,
    Verdict,
    identifiability,
    largest_total_index,
    sample_solutions,
    sensitivity_indices,
    simulation_noise_sd,
)
from demcal.daemon.control import saved_optimizer
from demcal.errors import ConfigError, DemcalError
from demcal.optimizer.bounds import from_unit_box, to_unit_box
from demcal.optimizer.membership import (
    BAND_SD,
    LIKELY,
    SURE,
    band_half_width,
    membership_probability,
)
from demcal.optimizer.responses import (
    ResponsePredictor,
    final_means,
    replicate_scatter,
)
from demcal.reporting.figures import PngTarget, ReportFigure, finish_figure, new_figure, save_png
from demcal.results.layout import BEST_FILE
from demcal.results.storage import read_json
from demcal.snakemake_command import ScriptJob
from demcal.study.model import Study, load_frozen

#: Most points drawn in the corner plot (a thinned, seeded subset of the set).
CORNER_POINTS = 3000
#: Resolution of the solution-space figures' PNG files [dots per inch].
SOLUTION_DPI = 100


@dataclass(frozen=True)
class SolutionAnalysis:
    """The solution space of a study, as `demcal solutions` finds it.

    ``solutions``: the parameter sets that the response models cannot rule
    out (a `SolutionSet`, in unit coordinates;
    [`points`][demcal.analysis.solution_report.SolutionAnalysis.points] gives them
    in real units); ``verdicts``: one [`Verdict`][demcal.analysis.solutions.Verdict]
    per free parameter, in the order of ``names``; ``sensitivity``: one row per
    response and parameter with its first-order (``S1``) and total (``ST``) Sobol
    index; ``lower``, ``upper``: the bounds; ``predictor``: the response models
    the analysis used.
    """

    predictor: ResponsePredictor
    solutions: SolutionSet
    verdicts: list[Verdict]
    sensitivity: list[dict[str, Any]]
    names: list[str]
    lower: np.ndarray
    upper: np.ndarray

    def in_real_units(self, points_unit: np.ndarray) -> np.ndarray:
        """Points of the unit box (one row each) in the parameters' units."""
        return from_unit_box(points_unit, self.lower, self.upper)

    def points(self) -> np.ndarray:
        """The accepted parameter sets in real units."""
        return self.in_real_units(self.solutions.points_unit)


def analyse(
    study: Study, k: float = BAND_SD, samples: int = 2**16, seed: int = 0
) -> SolutionAnalysis:
    """The solution space and identifiability of ``study`` from its saved evaluations."""
    if not study.files.optimizer.exists():
        raise DemcalError(
            f"study {study.name!r} has no evaluations yet ({study.files.optimizer} missing); "
            f"run the calibration first"
        )
    optimizer = saved_optimizer(study)
    predictor = optimizer.response_predictor(study.objective, levels=True)
    dimension = optimizer.bounds.dimension
    if predictor is None:
        raise DemcalError(
            f"study {study.name!r}: too few evaluations with responses to model them "
            f"(every targeted response needs at least {dimension + 2})"
        )
    observed = {key: final_means(optimizer.records, key, dimension) for key in predictor.models}
    scatter = {key: replicate_scatter(optimizer.records, key) for key in predictor.models}
    noise = simulation_noise_sd(predictor, observed, scatter)
    return analyse_predictor(
        predictor,
        noise,
        [p.name for p in study.free],
        [p.spec.unit for p in study.free],
        np.array(optimizer.bounds.lower),
        np.array(optimizer.bounds.upper),
        f"demcal solutions --explore 8 {study.name}",
        k,
        samples,
        seed,
    )


def analyse_predictor(
    predictor: ResponsePredictor,
    noise: dict[str, float],
    names: list[str],
    units: list[str],
    lower: np.ndarray,
    upper: np.ndarray,
    explore_command: str,
    k: float = BAND_SD,
    samples: int = 2**16,
    seed: int = 0,
) -> SolutionAnalysis:
    """The solution set, sensitivity and verdicts of any response models over a box (``noise``:
    the single-simulation scatter per response; ``explore_command``: what the verdicts suggest
    where the models cannot decide)."""
    solutions = sample_solutions(predictor, len(names), noise, k, samples, seed)
    sensitivity = sensitivity_indices(predictor, names, seed=seed)
    verdicts = identifiability(
        solutions, names, units, lower, upper, largest_total_index(sensitivity), explore_command
    )
    return SolutionAnalysis(predictor, solutions, verdicts, sensitivity, names, lower, upper)


@dataclass(frozen=True)
class PointCheck:
    """One parameter set judged against the targets on the study's response models.

    ``probability``: that every noise-free response meets its target within
    k combined sd; per response: the predicted mean and sd there, and the
    half-width of the band it must lie in (k sqrt(spread² + noise²)).
    """

    probability: float
    predicted: dict[str, tuple[float, float]]
    half_width: dict[str, float]


def check_point(analysis: SolutionAnalysis, values: dict[str, float]) -> PointCheck:
    """`PointCheck` of the free-parameter ``values`` (every free parameter, in bounds;
    a ConfigError names the missing or out-of-bounds one)."""
    for name, lower, upper in zip(analysis.names, analysis.lower, analysis.upper):
        if name not in values:
            raise ConfigError(f"--point: give every free parameter; {name} is missing")
        if not lower <= values[name] <= upper:
            raise ConfigError(
                f"--point {name}={values[name]:g}: outside its bounds [{lower:g}, {upper:g}]"
            )
    x = np.array([values[name] for name in analysis.names])
    unit = to_unit_box(x, analysis.lower, analysis.upper)[None, :]
    means, stds = analysis.predictor.predict(unit)
    s = analysis.solutions
    targets = analysis.predictor.objective.targets
    probability = membership_probability(targets, means, stds, s.noise_sd, s.k)[0]
    return PointCheck(
        float(probability),
        {key: (float(means[key][0]), float(stds[key][0])) for key in means},
        {t.key: band_half_width(t, s.noise_sd[t.key], s.k) for t in targets},
    )


def solutions_table(analysis: SolutionAnalysis) -> pd.DataFrame:
    table = pd.DataFrame(analysis.points(), columns=analysis.names)
    table["membership_probability"] = analysis.solutions.probability
    for key in analysis.solutions.means:
        table[f"{key} predicted"] = analysis.solutions.means[key]
        table[f"{key} sd"] = analysis.solutions.stds[key]
    return table


def plot_corner(
    analysis: SolutionAnalysis,
    best: dict[str, Any] | None,
    path: PngTarget | None = None,
    seed: int = 0,
) -> ReportFigure:
    """Pairwise scatter of the solution set, a histogram per parameter, the best point in red.

    Blue: in the set on the simulations' evidence; orange: likely in, not
    decided yet; grey: not ruled out, but more likely out.
    """
    points, names, d = analysis.points(), analysis.names, len(analysis.names)
    probability = analysis.solutions.probability
    if len(points) > CORNER_POINTS:
        keep = np.random.default_rng(seed).choice(len(points), CORNER_POINTS, replace=False)
        points, probability = points[keep], probability[keep]
    groups = [
        (probability >= SURE, "tab:blue"),
        ((probability >= LIKELY) & (probability < SURE), "tab:orange"),
        (probability < LIKELY, "lightgrey"),
    ]
    size = max(2.2, 9.0 / d)
    fig = new_figure(size * d, size * d)
    axes = fig.subplots(d, d, squeeze=False)
    best_x = None if best is None else [best["parameters"][name] for name in names]
    for row in range(d):
        for col in range(d):
            ax = axes[row, col]
            if col > row:
                ax.set_visible(False)
                continue
            if col == row:
                if len(points):
                    ax.hist(
                        [points[group, col] for group, _ in groups],
                        bins=30,
                        stacked=True,
                        range=(analysis.lower[col], analysis.upper[col]),
                        color=[colour for _, colour in groups],
                    )
                if best_x is not None:
                    ax.axvline(best_x[col], color="tab:red")
                ax.set_yticks([])
            else:
                for group, colour in reversed(groups):  # the decided points drawn last, on top
                    ax.scatter(
                        points[group, col],
                        points[group, row],
                        s=2,
                        alpha=0.3,
                        color=colour,
                        rasterized=True,
                    )
                if best_x is not None:
                    ax.plot(best_x[col], best_x[row], marker="*", color="tab:red", markersize=12)
                ax.set_ylim(analysis.lower[row], analysis.upper[row])
                if col == 0:
                    ax.set_ylabel(names[row])
            ax.set_xlim(analysis.lower[col], analysis.upper[col])
            if row == d - 1:
                ax.set_xlabel(names[col])
    s = analysis.solutions
    fig.suptitle(
        f"Parameter sets that may meet every target within {s.k:g} sd: {len(s.points_unit)} of "
        f"{s.sampled} sampled\nblue: in the set on the simulations' evidence; orange: likely, not "
        "decided yet; grey: not ruled out; best point in red",
        fontsize="medium",
    )
    return finish_figure(fig, path, SOLUTION_DPI)


def plot_objective_slices(
    analysis: SolutionAnalysis,
    best: dict[str, Any] | None,
    path: PngTarget | None = None,
    grid: int = 60,
) -> ReportFigure:
    """The predicted objective over pairs of the (up to three) most influential parameters, the
    others held at the best point: where the answer lies and how sharp its valley is."""
    names, d = analysis.names, len(analysis.names)
    largest = largest_total_index(analysis.sensitivity)
    chosen = sorted(range(d), key=lambda i: -largest.get(names[i], 0.0))[:3]
    pairs = [(a, b) for n, a in enumerate(chosen) for b in chosen[n + 1 :]] or [(0, 0)]
    centre = (
        np.full(d, 0.5)
        if best is None
        else (np.array([best["parameters"][n] for n in names]) - analysis.lower)
        / (analysis.upper - analysis.lower)
    )
    fig = new_figure(4.6 * len(pairs), 4.0)
    axes = fig.subplots(1, len(pairs), squeeze=False)
    axis = np.linspace(0.0, 1.0, grid)

    def scale(k: int, t: float | np.ndarray) -> np.ndarray:
        """Unit-box coordinate ``t`` of parameter ``k`` in its units."""
        return from_unit_box(t, analysis.lower[k], analysis.upper[k])

    for ax, (i, j) in zip(axes[0], pairs):
        if i == j:
            ax.set_axis_off()
            ax.text(0.5, 0.5, "one free parameter: no slice", ha="center")
            continue
        u, v = np.meshgrid(axis, axis)
        points = np.tile(centre, (grid * grid, 1))
        points[:, i], points[:, j] = u.ravel(), v.ravel()
        objective = np.maximum(analysis.predictor.objective_mean(points), 1e-12).reshape(grid, grid)
        filled = ax.contourf(
            scale(i, u), scale(j, v), np.log10(objective), levels=20, cmap="viridis_r"
        )
        fig.colorbar(filled, ax=ax, label="log10 predicted objective")
        ax.plot(scale(i, centre[i]), scale(j, centre[j]), "*", color="red", markersize=12)
        ax.set_xlabel(names[i])
        ax.set_ylabel(names[j])
    fig.suptitle(
        "Predicted objective through the best point (red star), other parameters held there",
        fontsize="medium",
    )
    return finish_figure(fig, path, SOLUTION_DPI)


def plot_sensitivity(rows: list[dict[str, Any]], path: PngTarget | None = None) -> ReportFigure:
    """Total (light) and first-order (dark) Sobol index of each parameter, one
    panel per response."""
    table = pd.DataFrame(rows)
    responses = list(dict.fromkeys(table["response"]))
    columns = min(2, len(responses))
    grid_rows = -(-len(responses) // columns)
    height = 1.4 + 0.35 * table["parameter"].nunique()
    fig = new_figure(5.5 * columns, height * grid_rows)
    axes = fig.subplots(grid_rows, columns, squeeze=False)
    for ax in axes.flat[len(responses) :]:
        ax.set_visible(False)
    for ax, response in zip(axes.flat, responses):
        part = table[table["response"] == response]
        y = np.arange(len(part))
        ax.barh(
            y,
            part["ST"].clip(lower=0),
            color="tab:blue",
            alpha=0.35,
            label="total (alone and with others)",
        )
        ax.barh(y, part["S1"].clip(lower=0), color="tab:blue", label="first order (alone)")
        ax.set_yticks(y, part["parameter"])
        ax.set_xlim(0, 1)
        ax.set_title(response, fontsize="medium")
        ax.set_xlabel("share of the response's variance over the box")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=2, fontsize="small")
    fig.suptitle(
        "Sensitivity of each response to each parameter (Sobol indices on the response models)",
        fontsize="medium",
    )
    return finish_figure(fig, path, SOLUTION_DPI, rect=(0, 0.06, 1, 1))


def write_solutions(
    study: Study, k: float = BAND_SD, samples: int = 2**16, seed: int = 0
) -> SolutionAnalysis:
    """Analyse the study and write its solution files and figures (see the module docstring)."""
    files = study.files
    analysis = analyse(study, k, samples, seed)
    files.plots.mkdir(parents=True, exist_ok=True)
    solutions_table(analysis).to_csv(files.solutions, index=False, float_format="%.6g")
    pd.DataFrame(analysis.sensitivity).to_csv(
        files.plots / "sensitivity.csv", index=False, float_format="%.3f"
    )
    s = analysis.solutions
    summary = {
        "k": s.k,
        "sampled": s.sampled,
        "possible": int(len(s.points_unit)),
        "likely": int(np.sum(s.likely)),
        "undecided_share": s.unsure_share,
        "simulation_noise_sd": s.noise_sd,
        "target_spread": {t.key: t.spread for t in study.targets},
        "verdicts": [asdict(v) for v in analysis.verdicts],
        "posterior": {
            "interval_90": {v.name: [v.posterior_low, v.posterior_high] for v in analysis.verdicts},
            "correlation": s.posterior.correlation.round(3).tolist(),
            "effective_samples": s.posterior.effective_samples,
        },
    }
    files.solutions_summary.write_text(json.dumps(summary, indent=2, default=float))
    best = read_json(files.best, BEST_FILE) if files.best.exists() else None
    plot_corner(analysis, best, files.plots / "solution_space.png", seed)
    plot_sensitivity(analysis.sensitivity, files.plots / "sensitivity.png")
    plot_objective_slices(analysis, best, files.plots / "objective_slices.png")
    return analysis


def write_solution_files(smk: ScriptJob) -> None:
    """Entry point of the workflow's solutions job: the figures, or figures saying
    why there are none."""
    import logging

    logging.basicConfig(filename=smk.log[0], level=logging.INFO, force=True)
    study = load_frozen(smk.params.study_file)
    try:
        write_solutions(study)
    except Exception as exc:  # noqa: BLE001  (the report must still be made; the figures say why)
        logging.exception("no solution space")
        fig = new_figure(6, 1.5)
        ax = fig.subplots()
        ax.axis("off")
        ax.text(0.5, 0.5, f"No solution space: {exc}", ha="center", va="center", wrap=True)
        for path in smk.output:
            save_png(fig, Path(path), SOLUTION_DPI)
