"""Error against run time: one point of a scene at several time steps and sizes.

``demcal convergence CONFIG`` runs the study's centre point (or ``--point``)
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

import pandas as pd

from demcal.engines.base import SimulationJob
from demcal.errors import ConfigError, DemcalError
from demcal.jobs.evaluation import run_engine, scene_responses
from demcal.physics.timestep import check_fraction
from demcal.results.records import Status
from demcal.results.storage import atomic_write_text
from demcal.study.config import default, load_study_file
from demcal.study.model import Study

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
) -> dict:
    """The scene's settings at ``variant``'s size for the free values ``point``, checked
    (errors name ``field``)."""
    size_setting = study.scenes[scene].size_setting
    settings = study.settings_for(scene, point)
    if size_setting == "particle_count":
        settings["d50"] *= (settings["particle_count"] / variant.size) ** (1.0 / 3.0)
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
) -> dict:
    """One simulation of ``variant``; returns its responses and cost (a failure
    keeps its reason)."""
    study = load_study_file(config)
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
        stop_file=str(Path(workdir) / "STOP"),
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


def run(
    config: str,
    scene: str | None,
    fractions: list[float] | None,
    sizes: list[float] | None,
    seeds: int,
    jobs: int,
    point_overrides: list[str],
) -> Path:
    """Run the study and write its files; returns the summary CSV's path."""
    config = str(Path(config).resolve())
    study = load_study_file(config)
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
    out = study.files.convergence
    out.mkdir(parents=True, exist_ok=True)
    tasks = [(v, k) for v in variants for k in range(seeds)]
    print(
        f"demcal convergence: {scene}, {len(variants)} variants x {seeds} seeds = "
        f"{len(tasks)} simulations, {jobs} at a time; configured {base.label}",
        flush=True,
    )
    rows = []
    with ProcessPoolExecutor(jobs) as pool:
        futures = [
            pool.submit(
                run_variant,
                config,
                scene,
                v,
                k,
                point,
                str((out / scene / v.label / f"seed{k}").resolve()),
            )
            for v, k in tasks
        ]
        for done, future in enumerate(futures, 1):
            row = future.result()
            rows.append(row)
            atomic_write_text(out / f"{scene}.csv", pd.DataFrame(rows).to_csv(index=False))
            print(
                f"  [{done}/{len(tasks)}] dt {row['fraction']:g} T_R, {size_setting} "
                f"{row['size']:g}, seed {row['seed_index']}: {row['status']} "
                f"({row['cpu_s'] or 0:.0f} s CPU) {row['reason']}",
                flush=True,
            )
    return write_summary(
        out, scene, pd.DataFrame(rows), study.responses_needed(scene), base, size_setting
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
    with pd.option_context("display.width", 250, "display.max_columns", 40):
        print(summary.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    print(f"demcal convergence: table {summary_path}, plot {out / f'{scene}.png'}")
    return summary_path
