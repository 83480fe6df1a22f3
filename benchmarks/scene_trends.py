"""Trends of a scene's responses with single parameters, on the study's engine (real LAMMPS).

    python benchmarks/scene_trends.py CONFIG --vary NAME=V1,V2,... [NAME=...] [--seeds 2]
                                      [--jobs 1] [--scene NAME]

Each free parameter named by ``--vary`` takes its values in turn, the others
at the centre of their bounds; every point runs ``--seeds`` seeds through
``benchmarks/scene_noise.py`` (its files noise_<study>_<scene>_trend_<name>_<value>.json
are read again by a later run instead of simulating anew). Prints and writes
benchmarks/results/trends_<study>_<scene>.md (a table of the mean and standard
deviation of every targeted response per value, with the CPU per simulation,
and whether each response rises or falls monotonically) and .png (one panel
per response and parameter).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from demcal.study.config import load_study  # noqa: E402
from demcal.study.study_file import read_study_yaml  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"


def sweep(text: str) -> tuple[str, list[float]]:
    """``NAME=V1,V2,...`` as the parameter's name and its values."""
    name, _, values = text.partition("=")
    return name, [float(v) for v in values.split(",")]


def point_runs(args: argparse.Namespace, study: str, scene: str, name: str, value: float) -> list:
    """The successful runs at ``name`` = ``value`` (simulated now unless on file)."""
    tag = f"trend_{name}_{value:g}"
    found = RESULTS / f"noise_{study}_{scene}_{tag}.json"
    if not found.exists():
        subprocess.run(
            [sys.executable, str(ROOT / "benchmarks" / "scene_noise.py"), args.config,
             "--scene", scene, "--seeds", str(args.seeds), "--jobs", str(args.jobs),
             "--point", f"{name}={value}", "--tag", tag],
            check=True,
        )  # fmt: skip
    return [r for r in json.loads(found.read_text())["runs"] if r["status"] == "ok"]


def direction(means: list[float], sds: list[float], seeds: int) -> str:
    """'rises' or 'falls' if every step that exceeds twice its standard error (from the seeds'
    standard deviations) goes that way, naming the steps flat within that noise; 'flat' if
    none does; else 'not monotone'."""
    steps = [
        (b - a, 2.0 * ((sa**2 + sb**2) / seeds) ** 0.5)
        for a, b, sa, sb in zip(means, means[1:], sds, sds[1:], strict=False)
    ]
    up = [step > noise for step, noise in steps]
    down = [step < -noise for step, noise in steps]
    flat = len(steps) - sum(up) - sum(down)
    note = f" ({flat} of {len(steps)} steps flat within the noise)" if flat else ""
    if any(up) and not any(down):
        return "rises" + note
    if any(down) and not any(up):
        return "falls" + note
    return "flat" if not any(up) else "not monotone"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config")
    parser.add_argument("--vary", nargs="+", required=True, metavar="NAME=V1,V2,...")
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--scene", help="default: the study's first scene")
    args = parser.parse_args()
    args.config = str(Path(args.config).resolve())
    study = load_study(read_study_yaml(args.config))
    scene = args.scene or next(iter(study.scenes))
    responses = study.responses_needed(scene)
    sweeps = [sweep(text) for text in args.vary]
    lines = [
        f"# Trends of {scene} ({study.name}), {args.seeds} seeds per point",
        "",
        f"Command: `python benchmarks/scene_trends.py {os.path.relpath(args.config, ROOT)} "
        f"--vary {' '.join(args.vary)} --seeds {args.seeds}`; the other free parameters at "
        f"{study.centre_point()}.",
        "",
        "| parameter | value | " + " | ".join(responses) + " | CPU s per run |",
        "|---|---|" + "---|" * len(responses) + "---|",
    ]
    figure, axes = plt.subplots(
        len(responses), len(sweeps), figsize=(4 * len(sweeps), 3 * len(responses)), squeeze=False
    )
    verdicts = []
    for column, (name, values) in enumerate(sweeps):
        means: dict[str, list[float]] = {r: [] for r in responses}
        sds: dict[str, list[float]] = {r: [] for r in responses}
        for value in values:
            runs = point_runs(args, study.name, scene, name, value)
            cells = []
            for response in responses:
                sample = [r[response] for r in runs]
                sd = statistics.stdev(sample) if len(sample) > 1 else 0.0
                means[response].append(statistics.fmean(sample))
                sds[response].append(sd)
                cells.append(f"{means[response][-1]:.4g} ± {sd:.2g}")
                axes[responses.index(response)][column].errorbar(
                    value, means[response][-1], yerr=sd, fmt="o", color="C0"
                )
            cpu = statistics.fmean(r["cpu_s"] for r in runs)
            lines.append(f"| {name} | {value:g} | " + " | ".join(cells) + f" | {cpu:.0f} |")
        for row, response in enumerate(responses):
            axes[row][column].plot(values, means[response], color="C0")
            axes[row][column].set(xlabel=name, ylabel=response)
            verdict = direction(means[response], sds[response], args.seeds)
            verdicts.append(f"- {response} {verdict} with {name}")
    lines += ["", *verdicts]
    figure.tight_layout()
    stem = RESULTS / f"trends_{study.name}_{scene}"
    figure.savefig(stem.with_suffix(".png"), dpi=100)
    stem.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
