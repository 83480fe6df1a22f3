"""``demcal advise``'s words, figure and files: the ranking of the candidate tests, each
candidate response over the solution set, ``advice.json`` and the joint study file."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from demcal.analysis.advice import PlaneFit, Shrink
from demcal.analysis.solution_report import SolutionAnalysis
from demcal.reporting.figures import ReportFigure, finish_figure, new_figure
from demcal.reporting.terminal import duration


@dataclass(frozen=True)
class Advice:
    """A finished advice: the candidates ranked (`rank`), best first, for the ``chosen``
    parameters (a mask over ``analysis.names``); ``sets``: the K sets simulated (unit box);
    ``values``: per candidate response key, its mean at each of them; ``fits``: its plane."""

    analysis: SolutionAnalysis
    chosen: np.ndarray
    ranked: list[Shrink]
    sets: np.ndarray
    values: dict[str, np.ndarray]
    fits: dict[str, PlaneFit]

    def sentence(self, shrink: Shrink) -> str:
        """What measuring one candidate would do, in words: each chosen parameter's likely span
        now and its expected width after, with the range over the truths."""
        parts = []
        verdicts = self.analysis.verdicts
        for i in np.flatnonzero(self.chosen):
            v = verdicts[i]
            widths = shrink.highs[:, i] - shrink.lows[:, i]
            unit = "" if v.unit in ("-", "") else f" {v.unit}"
            now = f"{v.low:.3g}–{v.high:.3g}{unit} ({100 * shrink.before[i]:.0f} % of its box)"
            if np.all(np.isnan(widths)):
                parts.append(f"{v.name} from {now}: no set stays likely at any truth")
                continue
            width = shrink.after[i] * (v.upper - v.lower)
            parts.append(
                f"{v.name} from {now} to a span of about {width:.3g}{unit} "
                f"({100 * shrink.after[i]:.0f} %; {100 * np.nanmin(widths):.0f}–"
                f"{100 * np.nanmax(widths):.0f} % over the {len(widths)} truths)"
            )
        cost = (
            "CPU per simulation not known"
            if math.isnan(shrink.cpu_s)
            else f"{duration(shrink.cpu_s)} CPU per simulation"
        )
        return (
            f"measuring the {shrink.scene.replace('_', ' ')}'s {shrink.response} (spread "
            f"{shrink.spread:.3g} {shrink.unit}) would narrow " + "; ".join(parts) + f" ({cost})"
        )


def plot(advice: Advice, path: Path | None = None) -> ReportFigure:
    """Each candidate response over the likely set, one panel each in ranked order: the set's
    points on the two most open parameters (one: the response against it), coloured by the
    plane's prediction, and the K simulated sets with their values."""
    analysis = advice.analysis
    s = analysis.solutions
    likely = s.points_unit[s.likely]
    open_first = np.argsort([0.0 if math.isnan(v.share) else -v.share for v in analysis.verdicts])
    axes_of = list(open_first[:2])
    columns = min(3, len(advice.ranked))
    rows = math.ceil(len(advice.ranked) / columns)
    fig = new_figure(3.8 * columns, 3.3 * rows)
    grid = fig.subplots(rows, columns, squeeze=False)
    for ax in grid.flat[len(advice.ranked) :]:
        ax.set_visible(False)
    points, sets = analysis.in_real_units(likely), analysis.in_real_units(advice.sets)
    for n, (ax, shrink) in enumerate(zip(grid.flat, advice.ranked)):
        fit = advice.fits[shrink.key]
        first = axes_of[0]
        if len(axes_of) == 1:
            order = np.argsort(likely[:, first])
            ax.plot(points[order, first], fit.predict(likely[order]), color="tab:orange", lw=1.2)
            ax.scatter(sets[:, first], advice.values[shrink.key], s=22, color="k", zorder=3)
            ax.set_ylabel(f"{shrink.response} [{shrink.unit}]", fontsize=8)
        else:
            second = axes_of[1]
            shade = ax.scatter(
                points[:, first], points[:, second], c=fit.predict(likely), s=4, cmap="viridis"
            )
            ax.scatter(
                sets[:, first],
                sets[:, second],
                c=advice.values[shrink.key],
                s=40,
                cmap="viridis",
                edgecolors="k",
                norm=shade.norm,
                zorder=3,
            )
            fig.colorbar(shade, ax=ax).set_label(f"{shrink.response} [{shrink.unit}]", fontsize=8)
            ax.set_ylabel(analysis.names[second], fontsize=8)
        ax.set_xlabel(analysis.names[first], fontsize=8)
        ax.set_title(
            f"{n + 1}. {shrink.scene}.{shrink.response}\nexpected span "
            f"{100 * shrink.score(advice.chosen):.0f} % of the box",
            fontsize=8,
        )
        ax.tick_params(labelsize=7)
    return finish_figure(fig, path)


def advice_record(advice: Advice, study: str, joint_files: dict[str, str]) -> dict[str, Any]:
    """``advice.json``: the ranking with each candidate's expected spans and sentence."""
    names = advice.analysis.names
    return {
        "study": study,
        "parameters": [n for n, c in zip(names, advice.chosen) if c],
        "sets": len(advice.sets),
        "ranking": [
            {
                "scene": s.scene,
                "response": s.response,
                "unit": s.unit,
                "spread": s.spread,
                "score": s.score(advice.chosen),
                "expected_share": dict(zip(names, map(float, s.after))),
                "share_now": dict(zip(names, map(float, s.before))),
                "cpu_s": s.cpu_s,
                "sentence": advice.sentence(s),
                "joint_study": joint_files.get(s.key),
            }
            for s in advice.ranked
        ],
    }


def joint_study_yaml(
    raw: dict[str, Any],
    study_scenes: list[str],
    name: str,
    scene: str,
    settings: dict[str, Any],
    target: dict[str, Any],
    archive: bool,
    path: Path,
) -> str:
    """The study file of the joint calibration: the study's own YAML mapping (its scenes
    ``study_scenes``) with the advised test added as a scene (``settings``: the material's,
    carried over) and its target with no value yet, under the name ``name``, reusing the
    archive's runs; ``path``: where it is written, for the command in its header."""
    joint = {key: value for key, value in raw.items() if key != "study"}
    joint = {"study": name, **joint}
    given = raw.get("scenes") or {}
    joint["scenes"] = {
        **{name: given.get(name) or {} for name in study_scenes},
        scene: {"settings": settings} if settings else {},
    }
    joint["targets"] = [*raw["targets"], target]
    if archive:
        joint["reuse"] = "archive"
    index = len(joint["targets"]) - 1
    header = (
        f"# Joint calibration written by demcal advise: the study {raw.get('study')!r} and the\n"
        f"# advised test, {scene}. Measure {target['response']} in the lab and write it as\n"
        f"# targets[{index}].value (its spread is demcal's typical one: give yours); then\n"
        f"#   demcal run {path}\n"
        + (
            "# It starts from the archive's runs of both tests at the same parameter sets.\n"
            if archive
            else ""
        )
    )
    return header + yaml.safe_dump(joint, sort_keys=False, allow_unicode=True)
