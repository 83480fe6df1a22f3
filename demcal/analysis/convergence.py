"""Error against run time: one point of a scene at several time steps and sizes.

``demcal convergence STUDY`` runs the study's centre point (or ``--point``)
for two sweeps: each time-step fraction of the Rayleigh time at the
configured size, and each size (the scene's ``size_setting``) at the
configured fraction. Each variant runs with the same ``--seeds`` seeds. For
every response it reports the relative deviation of the seed mean from its
own sweep's finest run (time-step sweep: the smallest fraction; size sweep:
the largest size), next to the seed-to-seed spread and the CPU time per
simulation. Output: ``results/<study>/convergence/<scene>.csv`` (every run,
rewritten as each one ends), ``<scene>_summary.csv`` and ``<scene>.png``.

A size is the particle count at the same volume of material (``d50``
scaled by (N0 / N)^(1/3), so the geometry and the amount stay and only the
resolution changes), or for the shear box its box scale ``box_size_dmax``
(the box in largest particles, Richter & Will's scale factor).
"""

from __future__ import annotations

import statistics
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from demcal.engines.base import SimulationJob
from demcal.errors import ConfigError, DemcalError
from demcal.jobs.steps import run_engine, scene_responses
from demcal.physics.timestep import check_fraction
from demcal.results.layout import STOP_FILE
from demcal.results.records import Status
from demcal.results.storage import atomic_write_text
from demcal.scenes.base import fewer_particles
from demcal.study.config import load_study_file
from demcal.study.model import Study, load_frozen
from demcal.study.schema import default

DEFAULT_FRACTIONS = (0.5, 0.35, 0.25, 0.125)
#: Sizes tried by default, as multiples of the configured size.
DEFAULT_SIZE_FACTORS = (0.5, 1.0, 2.0)


@dataclass(frozen=True)
class Variant:
    """One resolution of the scene: time-step fraction and value of its size setting."""

    fraction: float
    size: float

    @property
    def label(self) -> str:
        return f"dt{self.fraction:g}_size{self.size:g}"


def variant_settings(
    study: Study, scene: str, variant: Variant, field: str, point: dict[str, float]
) -> dict[str, Any]:
    """The scene's settings at ``variant``'s size for the free values ``point``, checked
    (errors name ``field``)."""
    size_setting = study.scenes[scene].size_setting
    settings = study.settings_for(scene, point)
    if size_setting == "particle_count":
        settings.update(fewer_particles(settings, variant.size))
    settings[size_setting] = variant.size
    return study.scenes[scene].resolve_settings(settings, field)


def plan(
    study: Study, scene: str, fractions: list[float], sizes: list[float], point: dict[str, float]
) -> tuple[list[Variant], Variant]:
    """The variants of both sweeps and the configured (base) one; each is checked like a config
    at the free values ``point``."""
    size_setting = study.scenes[scene].size_setting
    base = Variant(study.timestep_fraction, study.settings[scene][size_setting])
    variants = sorted(
        {
            base,
            *(Variant(f, base.size) for f in fractions),
            *(Variant(base.fraction, s) for s in sizes),
        },
        key=lambda v: (v.size, -v.fraction),
    )
    for v in variants:
        check_fraction(v.fraction, default("timestep_fraction"), "--fractions")
        variant_settings(study, scene, v, f"--sizes ({size_setting})", point)
    return variants, base


def run_variant(
    config: str,
    scene: str,
    variant: Variant,
    seed_index: int,
    point: dict[str, float],
    workdir: str,
) -> dict[str, Any]:
    """One simulation of ``variant``; returns its responses and cost (a failure
    keeps its reason)."""
    study = load(config)
    settings = variant_settings(study, scene, variant, "settings", point)
    Path(workdir).mkdir(parents=True, exist_ok=True)
    job = SimulationJob(
        scene=scene,
        parameters=study.parameters_for(point),
        settings=settings,
        seed=study.simulation_seed("convergence", scene, seed_index),
        responses=study.responses_needed(scene),
        timestep_fraction=variant.fraction,
        workdir=workdir,
        stop_file=str(Path(workdir) / STOP_FILE),
    )
    result = run_engine(study, job)
    row = {
        "fraction": variant.fraction,
        "size": variant.size,
        "d50": settings["d50"],
        "seed_index": seed_index,
        "status": result.status,
        "reason": result.reason,
        "wall_s": result.cost.get("wall_s"),
        "cpu_s": result.cost.get("cpu_s"),
        "steps": result.cost.get("steps"),
    }
    if result.status == Status.OK:
        try:
            row.update(
                scene_responses(
                    study.scenes[scene],
                    job.responses,
                    result.measurements,
                    lambda: result.arrays,
                    settings,
                )
            )
        except DemcalError as exc:
            row.update(status=Status.FAILED, reason=str(exc))
    return row


def _relative_pct(value: float, reference: float) -> float:
    return 100.0 * (value - reference) / reference if reference else float("nan")


def summarise(runs: pd.DataFrame, responses: list[str], base: Variant) -> pd.DataFrame:
    """Per variant: seed mean of each response, deviations from the sweeps' finest runs [%].

    ``<response>_dt_deviation_pct`` (variants at the base size) compares with
    the smallest time step at that size; ``<response>_size_deviation_pct``
    (variants at the base fraction) with the largest size at that fraction;
    ``<response>_noise_pct`` is the seed-to-seed standard deviation relative
    to the mean. Failed runs are listed with their reason.
    """
    ok = runs[runs["status"] == Status.OK]
    means = ok.groupby(["fraction", "size"])[responses].mean()
    dt_sweep = means.xs(base.size, level="size", drop_level=False) if len(means) else means
    size_sweep = (
        means.xs(base.fraction, level="fraction", drop_level=False) if len(means) else means
    )
    finest_dt = dt_sweep.loc[dt_sweep.index.min()] if len(dt_sweep) else None
    largest = size_sweep.loc[size_sweep.index.max()] if len(size_sweep) else None
    rows = []
    for (fraction, size), group in ok.groupby(["fraction", "size"]):
        row = {
            "fraction": fraction,
            "size": size,
            "runs_ok": len(group),
            "cpu_s": group["cpu_s"].mean(),
            "wall_s": group["wall_s"].mean(),
        }
        for name in responses:
            mean = group[name].mean()
            row[name] = mean
            row[f"{name}_dt_deviation_pct"] = (
                _relative_pct(mean, finest_dt[name])
                if size == base.size and finest_dt is not None
                else float("nan")
            )
            row[f"{name}_size_deviation_pct"] = (
                _relative_pct(mean, largest[name])
                if fraction == base.fraction and largest is not None
                else float("nan")
            )
            row[f"{name}_noise_pct"] = (
                100.0 * statistics.stdev(group[name]) / abs(mean)
                if len(group) > 1 and mean
                else float("nan")
            )
        rows.append(row)
    for _, run in runs[runs["status"] != Status.OK].iterrows():
        rows.append(
            {
                "fraction": run["fraction"],
                "size": run["size"],
                "runs_ok": 0,
                "failure": run["reason"],
            }
        )
    return pd.DataFrame(rows)


def plot(summary: pd.DataFrame, responses: list[str], size_setting: str, path: Path) -> None:
    """|deviation from the sweep's finest run| against CPU seconds, one panel per response."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = summary[summary["runs_ok"] > 0]
    fig, axes = plt.subplots(1, len(responses), figsize=(5.0 * len(responses), 4.0), squeeze=False)
    for ax, name in zip(axes[0], responses):
        for sweep, colour, label in (
            ("dt", "tab:blue", "time step"),
            ("size", "tab:orange", size_setting),
        ):
            rows = ok[ok[f"{name}_{sweep}_deviation_pct"].notna()]
            ax.scatter(
                rows["cpu_s"],
                rows[f"{name}_{sweep}_deviation_pct"].abs(),
                color=colour,
                label=f"{label} sweep",
            )
            for _, row in rows.iterrows():
                ax.annotate(
                    f"dt {row['fraction']:g}, {row['size']:g}",
                    (row["cpu_s"], abs(row[f"{name}_{sweep}_deviation_pct"])),
                    fontsize=7,
                    xytext=(3, 3),
                    textcoords="offset points",
                )
        noise = ok[f"{name}_noise_pct"].median()
        if noise == noise:  # not NaN
            ax.axhline(noise, color="tab:red", linestyle="--", label=f"seed noise {noise:.2g} %")
        ax.legend(fontsize=8)
        ax.set_xlabel("CPU seconds per simulation")
        ax.set_ylabel(f"|{name} - finest of its sweep| [%]")
        ax.set_title(name)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=100)
    plt.close(fig)
    tmp.replace(path)


def load(config: str) -> Study:
    """The study of ``config``: a YAML file, or the study.json a study that has run froze."""
    return load_frozen(config) if config.endswith(".json") else load_study_file(config)


@dataclass(frozen=True)
class Sweep:
    """What ``demcal convergence`` runs: the variants of one scene of a study at one point."""

    config: str
    study: Study
    scene: str
    variants: list[Variant]
    base: Variant
    point: dict[str, float]

    @property
    def size_setting(self) -> str:
        return self.study.scenes[self.scene].size_setting

    def relative_cost(self, variant: Variant) -> float:
        """A run of ``variant`` against one of the configured variant, by its time steps."""
        steps = self.study.engine.steps_in_time
        return self.base.fraction / variant.fraction if steps else 1.0

    def fractions(self) -> list[float]:
        """The time-step sweep's fractions, largest first."""
        return sorted({v.fraction for v in self.variants if v.size == self.base.size}, reverse=True)

    def sizes(self) -> list[float]:
        """The size sweep's values, smallest first."""
        return sorted({v.size for v in self.variants if v.fraction == self.base.fraction})

    def describe(self) -> str:
        """The scene, the configured variant and both sweeps, in two lines."""
        fractions, sizes = self.fractions(), self.sizes()
        return (
            f"{self.scene}, {len(self.variants)} variants (configured {self.base.label}):\n"
            f"  time steps {' '.join(f'{f:g}' for f in fractions)} T_R at "
            f"{self.size_setting} {self.base.size:g}; {self.size_setting} "
            f"{' '.join(f'{s:g}' for s in sizes)} at {self.base.fraction:g} T_R"
        )


def sweep(
    config: str,
    scene: str | None,
    fractions: list[float] | None,
    sizes: list[float] | None,
    point_overrides: list[str],
) -> Sweep:
    """The variants to run, checked (``config``: the study's YAML file or its study.json)."""
    config = str(Path(config).resolve())
    study = load(config)
    scene = scene or next(iter(study.scenes))
    if scene not in study.scenes:
        raise ConfigError(f"--scene {scene}: not a scene of the study ({', '.join(study.scenes)})")
    size_setting = study.scenes[scene].size_setting
    base_size = study.settings[scene][size_setting]
    if sizes is None:
        sizes = [f * base_size for f in DEFAULT_SIZE_FACTORS]
        if study.scenes[scene].settings[size_setting].integer:
            sizes = [float(round(s)) for s in sizes]
    point = study.centre_point(point_overrides)
    variants, base = plan(study, scene, list(fractions or DEFAULT_FRACTIONS), sizes, point)
    return Sweep(config, study, scene, variants, base, point)


def run(sweep: Sweep, seeds: int, workers: int) -> Path:
    """Run the sweep, ``seeds`` runs of each variant, ``workers`` at a time, and write its
    files; returns the summary CSV's path."""
    study, scene = sweep.study, sweep.scene
    out = study.files.convergence
    out.mkdir(parents=True, exist_ok=True)
    tasks = [(v, k) for v in sweep.variants for k in range(seeds)]
    rows = []
    with ProcessPoolExecutor(workers) as pool:
        futures = [
            pool.submit(
                run_variant,
                sweep.config,
                scene,
                v,
                k,
                sweep.point,
                str((out / scene / v.label / f"seed{k}").resolve()),
            )
            for v, k in tasks
        ]
        for done, future in enumerate(futures, 1):
            row = future.result()
            rows.append(row)
            atomic_write_text(out / f"{scene}.csv", pd.DataFrame(rows).to_csv(index=False))
            print(
                f"  [{done}/{len(tasks)}] dt {row['fraction']:g} T_R, {sweep.size_setting} "
                f"{row['size']:g}, seed {row['seed_index']}: {row['status']} "
                f"({row['cpu_s'] or 0:.0f} s CPU) {row['reason']}",
                flush=True,
            )
    return write_summary(
        out,
        scene,
        pd.DataFrame(rows),
        study.responses_needed(scene),
        sweep.base,
        sweep.size_setting,
    )


def write_summary(
    out: Path,
    scene: str,
    runs: pd.DataFrame,
    responses: list[str],
    base: Variant,
    size_setting: str,
) -> Path:
    """Summary CSV and plot of the runs; prints the table. Returns the CSV's path."""
    summary = summarise(runs, responses, base)
    summary_path = out / f"{scene}_summary.csv"
    atomic_write_text(summary_path, summary.to_csv(index=False))
    if (summary["runs_ok"] > 0).any():
        plot(summary, responses, size_setting, out / f"{scene}.png")
    print("\n".join(summary_table(summary, responses, size_setting)))
    print(f"demcal convergence: table {summary_path}, plot {out / f'{scene}.png'}")
    return summary_path


#: The widest line of the summary table; a longer failure reason is cut.
TABLE_WIDTH = 100


def summary_table(summary: pd.DataFrame, responses: list[str], size_setting: str) -> list[str]:
    """The summary as a terminal reads it: one small table per response (seed mean, deviation
    from the finest run of each sweep, seed noise), then the failed runs, within TABLE_WIDTH."""

    def number(value: float, digits: int) -> str:
        return "-" if value != value else f"{value:.{digits}g}"  # NaN: not in that sweep

    ok = summary[summary["runs_ok"] > 0]
    size_width = max(len(size_setting), 6)
    head = f"{'dt/T_R':>7} {size_setting:>{size_width}} {'runs':>4} {'CPU s':>9}"
    lines = []
    for name in responses:
        lines += [
            f"{name}: seed mean, deviation [%] from each sweep's finest run, seed noise [%]",
            f"{head} {'mean':>10} {'dt sweep':>9} {'size sweep':>10} {'noise':>7}",
        ]
        lines += [
            f"{row['fraction']:>7g} {row['size']:>{size_width}g} {row['runs_ok']:>4.0f} "
            f"{number(row['cpu_s'], 3):>9} {number(row[name], 4):>10} "
            f"{number(row[f'{name}_dt_deviation_pct'], 3):>9} "
            f"{number(row[f'{name}_size_deviation_pct'], 3):>10} "
            f"{number(row[f'{name}_noise_pct'], 2):>7}"
            for _, row in ok.iterrows()
        ]
    for _, row in summary[summary["runs_ok"] == 0].iterrows():
        line = (
            f"failed: dt {row['fraction']:g} T_R, {size_setting} {row['size']:g}: {row['failure']}"
        )
        lines.append(line if len(line) <= TABLE_WIDTH else line[: TABLE_WIDTH - 1] + "…")
    return lines
