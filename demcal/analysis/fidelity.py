"""Does a cheaper fidelity level pay? The figures of ``demcal fidelity check``.

The check runs the same Sobol points at every level of a study (a campaign, each point at
each level, ``replicates`` seeds each) and compares each cheaper level with the fine one, per
targeted response:

- the correlation r of single runs at the same point (replicate k at both levels), with its
  one-sided 90 % lower bound from Fisher's z (the verdict uses the bound, so that a few points
  do not promise more than they show);
- the scale and bias of the least-squares line fine = scale * coarse + bias over the points'
  replicate means, the linear link of multi-fidelity Kriging (Kennedy & O'Hagan 2000), and
  the scatter about it beyond both levels' noise (the discrepancy it leaves);
- each level's noise, the pooled sd of its replicates at a point, and its cost, the median
  CPU seconds of its simulations of the response's scene.

**Verdict.** A level pays for a response when a budget spent on both levels estimates it
with less variance than the same budget spent on fine runs alone: the rule of
:mod:`demcal.optimizer.levels` at the lower bound of r; the saving is 1 minus the variance
ratio.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from demcal.errors import SimulationFailed
from demcal.optimizer import levels
from demcal.optimizer.levels import CONFIDENCE, MIN_POINTS
from demcal.reporting.figures import ReportFigure, finish_figure, new_figure
from demcal.results.records import FINE, PointRecord, ResponsesRecord, Status
from demcal.study.model import Study


def runs_table(study: Study, names: list[str]) -> pd.DataFrame:
    """Every finished ok simulation of the evaluations ``names``, one row per targeted
    response: evaluation, level, point (the free values as a tuple), scene, replicate,
    response key (``scene.response``), value and cpu_s. Unreadable or failed ones are left
    out."""
    keys = {(t.scene, t.response) for t in study.targets}
    rows = []
    for name in names:
        files = study.files.evaluation(name)
        try:
            point = PointRecord.read(files.params)
        except SimulationFailed:
            continue
        values = tuple(float(point.parameters[p.name]) for p in study.free)
        for scene in study.scenes:
            for replicate in range(study.replicates):
                try:
                    record = ResponsesRecord.read(files.replicate(scene, replicate).responses)
                except SimulationFailed:
                    continue
                if record.status != Status.OK:
                    continue
                cpu = (record.cost or {}).get("cpu_s")
                rows += [
                    {
                        "evaluation": name,
                        "level": point.level,
                        "point": values,
                        "scene": scene,
                        "replicate": replicate,
                        "response": f"{scene}.{response}",
                        "value": value,
                        "cpu_s": float(cpu) if isinstance(cpu, int | float) else math.nan,
                    }
                    for response, value in record.responses.items()
                    if (scene, response) in keys
                ]
    columns = ["evaluation", "level", "point", "scene", "replicate", "response", "value", "cpu_s"]
    return pd.DataFrame(rows, columns=columns)


def pooled_noise(runs: pd.DataFrame) -> float:
    """The pooled sd of replicates at the same point (nan without a point run twice)."""
    variances = [
        (len(group) - 1, float(np.var(group, ddof=1)))
        for _, group in runs.groupby("point")["value"]
        if len(group) >= 2
    ]
    dof = sum(d for d, _ in variances)
    return math.sqrt(sum(d * v for d, v in variances) / dof) if dof else math.nan


def median_cpu(runs: pd.DataFrame, level: str, scene: str) -> float:
    """The median CPU seconds of one simulation of ``scene`` at ``level`` (nan if none says)."""
    simulations = runs[(runs["level"] == level) & (runs["scene"] == scene)].drop_duplicates(
        ["evaluation", "scene", "replicate"]
    )
    cpu = simulations["cpu_s"].dropna()
    return float(np.median(cpu)) if len(cpu) else math.nan


@dataclass(frozen=True)
class LevelComparison:
    """A cheaper level against the fine one for one response (the module's figures)."""

    level: str
    response: str
    points: int
    correlation: float
    correlation_lower: float
    scale: float
    bias: float
    discrepancy_sd: float
    noise_fine: float
    noise_level: float
    cpu_fine_s: float
    cpu_level_s: float

    @property
    def cost_ratio(self) -> float:
        return self.cpu_level_s / self.cpu_fine_s if self.cpu_fine_s > 0 else math.nan

    @property
    def variance_ratio(self) -> float:
        """The rule's variance ratio at the correlation's lower bound (:mod:`.levels`)."""
        return levels.variance_ratio(self.correlation_lower, self.cost_ratio)

    @property
    def pays(self) -> bool:
        return levels.ratio_pays(self.variance_ratio)

    @property
    def verdict(self) -> str:
        if self.points < MIN_POINTS:
            return f"unknown: {self.points} points ran at both levels, a verdict needs {MIN_POINTS}"
        if not math.isfinite(self.variance_ratio):
            return "unknown: no cost or correlation measured"
        if self.pays:
            return f"pays: saves {1.0 - self.variance_ratio:.0%} of the variance at equal CPU"
        return "does not pay: fine runs alone estimate it better for the same CPU"


def paired_means(runs: pd.DataFrame, level: str, response: str) -> pd.DataFrame:
    """Per point run at both levels, the replicate means of ``response`` at fine and at
    ``level`` (columns ``fine`` and ``level``)."""
    of = runs[runs["response"] == response]
    return pd.concat(
        [
            of[of["level"] == FINE].groupby("point")["value"].mean(),
            of[of["level"] == level].groupby("point")["value"].mean(),
        ],
        axis=1,
        keys=["fine", "level"],
    ).dropna()


def compare(runs: pd.DataFrame, level: str, response: str) -> LevelComparison:
    """``level`` against fine for one ``response`` from the check's ``runs`` (`runs_table`)."""
    of = runs[runs["response"] == response]
    fine, cheap = of[of["level"] == FINE], of[of["level"] == level]
    means = paired_means(runs, level, response)
    single = fine.merge(cheap, on=["point", "replicate"], suffixes=("_fine", "_level"))
    n = len(means)
    r = (
        float(np.corrcoef(single["value_level"], single["value_fine"])[0, 1])
        if len(single) >= 3
        else math.nan
    )
    scale = bias = spread = math.nan
    if n >= 3 and np.ptp(means["level"]) > 0:
        scale, bias = (float(c) for c in np.polyfit(means["level"], means["fine"], 1))
        residuals = means["fine"] - (scale * means["level"] + bias)
        spread = float(np.sqrt(np.sum(residuals**2) / (n - 2)))
    scene = of["scene"].iloc[0] if len(of) else ""
    cpu = {name: median_cpu(runs, name, scene) for name in (FINE, level)}
    lower = levels.correlation_lower_bound(r, len(single.groupby("point"))) if n else math.nan
    return LevelComparison(
        level=level,
        response=response,
        points=n,
        correlation=r,
        correlation_lower=lower,
        scale=scale,
        bias=bias,
        discrepancy_sd=spread,
        noise_fine=pooled_noise(fine),
        noise_level=pooled_noise(cheap),
        cpu_fine_s=cpu[FINE],
        cpu_level_s=cpu[level],
    )


def comparisons(study: Study, runs: pd.DataFrame) -> list[LevelComparison]:
    """Every cheaper level of the study against fine, for each targeted response."""
    responses = list(dict.fromkeys(t.key for t in study.targets))
    return [compare(runs, level, key) for level in study.fidelities for key in responses]


def table(found: list[LevelComparison]) -> pd.DataFrame:
    """The comparisons as the check's CSV rows, the verdict in words."""
    return pd.DataFrame(
        [
            {
                "level": c.level,
                "response": c.response,
                "points": c.points,
                "correlation": c.correlation,
                f"correlation_lower_{CONFIDENCE:.0%}": c.correlation_lower,
                "scale": c.scale,
                "bias": c.bias,
                "discrepancy_sd": c.discrepancy_sd,
                "noise_fine": c.noise_fine,
                "noise_level": c.noise_level,
                "cpu_fine_s": c.cpu_fine_s,
                "cpu_level_s": c.cpu_level_s,
                "cost_ratio": c.cost_ratio,
                "variance_ratio": c.variance_ratio,
                "pays": c.pays,
                "verdict": c.verdict,
            }
            for c in found
        ]
    )


def plot(
    runs: pd.DataFrame, found: list[LevelComparison], path: Path | None = None
) -> ReportFigure:
    """Fine against each cheaper level, one panel per level and response: the points'
    replicate means, the fitted line and the line of equal values."""
    names = list(dict.fromkeys(c.level for c in found))
    responses = list(dict.fromkeys(c.response for c in found))
    fig = new_figure(3.6 * len(responses), 3.4 * len(names))
    axes = fig.subplots(len(names), len(responses), squeeze=False)
    for c in found:
        ax = axes[names.index(c.level)][responses.index(c.response)]
        means = paired_means(runs, c.level, c.response)
        ax.scatter(means["level"], means["fine"], s=18, color="tab:blue", zorder=3)
        if len(means):
            low = float(min(means.min()))
            high = float(max(means.max()))
            line = np.array([low, high])
            ax.plot(line, line, ls=":", color="grey", lw=1, label="equal")
            if math.isfinite(c.scale):
                ax.plot(line, c.scale * line + c.bias, color="tab:orange", lw=1.2, label="fit")
        ax.set_xlabel(f"{c.response} at {c.level}", fontsize=8)
        ax.set_ylabel(f"{c.response} at {FINE}", fontsize=8)
        ax.set_title(
            f"r = {c.correlation:.2f}, scale {c.scale:.3g}, cost x{c.cost_ratio:.2f}\n"
            f"{'pays' if c.pays else 'does not pay'}",
            fontsize=8,
        )
        ax.tick_params(labelsize=7)
        ax.legend(fontsize=7)
    return finish_figure(fig, path)
