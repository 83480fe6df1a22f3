"""What the calibration daemon costs beyond the simulations, locally and through SLURM.

    python benchmarks/daemon_overhead.py [--durations 5 [30 ...]] [--evaluations 4]
        [--speedup-evaluations 10] [--no-slurm | --no-local] [--parts overhead speedup]
        [--out FILE]

Two measurements on the analytic engine (config/examples/analytic.yaml, one
replicate, no noise, a fixed fake simulation time, early termination off),
each a whole ``demcal run`` in a scratch directory:

- overhead per evaluation = its cycle (``launch.json`` started_at to the
  next evaluation's, one evaluation at a time, P=1: the daemon launches the
  next point once it has taken the result) minus simulation wall time
  (``simulation.json`` cost.wall_s), split into before the simulation
  (child Snakemake start, SLURM submission and job start) and after it
  (extract, the daemon's poll and its next proposal); with profiles/local
  and profiles/slurm, for each of ``--durations``. Also when objective.json
  was written after the simulation: through SLURM the child Snakemake
  writes it only after the executor's next status check, 1 s after
  submission (the profile's init delay), then at intervals growing by 10 s
  while nothing finishes (1, 12, 33, 64 s ...);
- speedup of P=2 over P=1: wall time of ``demcal run`` for
  ``--speedup-evaluations`` evaluations of the first duration, with one and
  with two in flight.

SLURM runs need a SLURM on this machine (.ci/slurm/start.sh). Wall times
include waiting for the CPU: the load average before and after is recorded,
run it on an otherwise idle machine. Prints markdown tables; writes
benchmarks/results/daemon_overhead.json (or --out).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

from demcal.study.config import load_study_file

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "config" / "examples" / "analytic.yaml"
OUT = ROOT / "benchmarks" / "results" / "daemon_overhead.json"


def write_study(workdir: Path, name: str, duration_s: float, evaluations: int) -> Path:
    """The analytic example as a study of ``evaluations`` runs of ``duration_s`` seconds each."""
    config = yaml.safe_load(EXAMPLE.read_text())
    config.update(
        study=name,
        replicates=1,
        engine={"name": "analytic", "noise": 0.0, "duration": duration_s},
        optimizer={"max_evaluations": evaluations, "early_termination": {"enabled": False}},
    )
    path = workdir / f"{name}.yaml"
    path.write_text(yaml.safe_dump(config))
    return path


def run_calibration(workdir: Path, config: Path, profile: str, workers: int, limit_s: int) -> float:
    """Run ``demcal run`` to its end; its wall time [s]."""
    command = [
        "timeout",
        "-k",
        "30",
        str(limit_s),
        sys.executable,
        "-m",
        "demcal.cli",
        "run",
        str(config),
        "--profile",
        str(ROOT / "profiles" / profile),
        "--workers",
        str(workers),
    ]
    start = time.monotonic()
    proc = subprocess.run(
        command, cwd=workdir, stdin=subprocess.DEVNULL, capture_output=True, text=True
    )
    wall = time.monotonic() - start
    if proc.returncode != 0:
        raise SystemExit(
            f"demcal run ({profile}, P={workers}) ended with {proc.returncode}:\n"
            f"{proc.stderr[-3000:]}"
        )
    return wall


def evaluation_times(workdir: Path, study: str) -> list[dict]:
    """Per evaluation but the last, one at a time: its cycle (its launch to the next
    evaluation's launch, i.e. until the daemon took its result and asked for the next point),
    the simulation's wall time, the overhead (the difference) and the part of it before and
    after the simulation [s]."""
    evaldirs = sorted((workdir / "results" / study / "evals").glob("e[0-9]*"))
    launches = [json.loads((d / "launch.json").read_text())["started_at"] for d in evaldirs]
    rows = []
    for evaldir, launched, next_launch in zip(evaldirs, launches, launches[1:]):
        sim = json.loads((evaldir / "cylinder_lift" / "rep0" / "simulation.json").read_text())
        if sim["status"] != "ok":
            raise SystemExit(f"{evaldir.name}: simulation {sim['status']}: {sim['reason']}")
        wall, sim_wall = next_launch - launched, sim["cost"]["wall_s"]
        rows.append(
            {
                "evaluation": evaldir.name,
                "wall_s": wall,
                "simulation_wall_s": sim_wall,
                "overhead_s": wall - sim_wall,
                "before_simulation_s": sim["started_at"] - launched,
                "after_simulation_s": next_launch - sim["ended_at"],
                "objective_written_after_s": (evaldir / "objective.json").stat().st_mtime
                - sim["ended_at"],
            }
        )
    return rows


def daemon_poll_seconds() -> float:
    """The daemon's poll interval these studies get (calibration.poll_seconds default)."""
    with tempfile.TemporaryDirectory() as scratch:
        return float(
            load_study_file(write_study(Path(scratch), "poll", 1.0, 1)).calibration["poll_seconds"]
        )


def summary(values: list[float]) -> dict:
    return {"median": statistics.median(values), "min": min(values), "max": max(values)}


def measure_overhead(scratch: Path, profile: str, duration_s: float, evaluations: int) -> dict:
    name = f"overhead-{profile}-{duration_s:g}s"
    workdir = scratch / name
    workdir.mkdir()
    config = write_study(workdir, name, duration_s, evaluations)
    run_calibration(
        workdir, config, profile, workers=1, limit_s=int(evaluations * (duration_s + 60) + 120)
    )
    rows = evaluation_times(workdir, name)
    return {
        "profile": profile,
        "duration_s": duration_s,
        "workers": 1,
        "evaluations": rows,
        **{
            key: summary([r[key] for r in rows])
            for key in (
                "wall_s",
                "simulation_wall_s",
                "overhead_s",
                "before_simulation_s",
                "after_simulation_s",
                "objective_written_after_s",
            )
        },
    }


def measure_speedup(scratch: Path, profile: str, duration_s: float, evaluations: int) -> dict:
    walls = {}
    for workers in (1, 2):
        workdir = scratch / f"speedup-{profile}-p{workers}"
        workdir.mkdir()
        config = write_study(workdir, f"speedup-p{workers}", duration_s, evaluations)
        walls[workers] = run_calibration(
            workdir, config, profile, workers, limit_s=int(evaluations * (duration_s + 60) + 120)
        )
    return {
        "profile": profile,
        "evaluations": evaluations,
        "duration_s": duration_s,
        "wall_p1_s": walls[1],
        "wall_p2_s": walls[2],
        "speedup": walls[1] / walls[2],
        "ideal_p1_s": evaluations * duration_s,
        "ideal_p2_s": -(-evaluations // 2) * duration_s,
    }


def markdown(result: dict) -> str:
    lines = [
        "| profile | simulation [s] | cycle [s] | overhead [s] "
        "| before sim [s] | after sim [s] | objective.json after sim [s] |",
        "|---|---|---|---|---|---|---|",
    ]
    for o in result.get("overhead", []):
        lines.append(
            f"| {o['profile']}, P=1 | {o['simulation_wall_s']['median']:.1f} "
            f"| {o['wall_s']['median']:.1f} "
            f"| {o['overhead_s']['median']:.1f} "
            f"({o['overhead_s']['min']:.1f}-{o['overhead_s']['max']:.1f}) "
            f"| {o['before_simulation_s']['median']:.1f} "
            f"| {o['after_simulation_s']['median']:.1f} "
            f"| {o['objective_written_after_s']['median']:.1f} |"
        )
    lines += [
        "",
        "| profile | evaluations | P=1 wall [s] | P=2 wall [s] | speedup "
        "| simulation time alone P=1 / P=2 [s] |",
        "|---|---|---|---|---|---|",
    ]
    for s in result.get("speedup", []):
        lines.append(
            f"| {s['profile']} | {s['evaluations']} x {s['duration_s']:g} s "
            f"| {s['wall_p1_s']:.1f} "
            f"| {s['wall_p2_s']:.1f} | {s['speedup']:.2f} "
            f"| {s['ideal_p1_s']:.0f} / {s['ideal_p2_s']:.0f} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--durations",
        type=float,
        nargs="+",
        default=[5.0],
        help="fake simulation times of the analytic engine [s]",
    )
    parser.add_argument(
        "--evaluations", type=int, default=4, help="evaluations per overhead measurement"
    )
    parser.add_argument("--speedup-evaluations", type=int, default=10)
    parser.add_argument("--no-slurm", action="store_true", help="local profile only")
    parser.add_argument("--no-local", action="store_true", help="SLURM profile only")
    parser.add_argument(
        "--parts", nargs="+", choices=["overhead", "speedup"], default=["overhead", "speedup"]
    )
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    profiles = ([] if args.no_local else ["local"]) + ([] if args.no_slurm else ["slurm"])
    result = {
        "command": " ".join(["python benchmarks/daemon_overhead.py", *sys.argv[1:]]),
        "started_at": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version()},
        "load_average_before": os.getloadavg(),
        "daemon_poll_s": daemon_poll_seconds(),
    }
    with tempfile.TemporaryDirectory(prefix="daemon_overhead_") as scratch:
        if "overhead" in args.parts:
            result["overhead"] = [
                measure_overhead(Path(scratch), p, d, args.evaluations)
                for d in args.durations
                for p in profiles
            ]
        if "speedup" in args.parts:
            result["speedup"] = [
                measure_speedup(Path(scratch), p, args.durations[0], args.speedup_evaluations)
                for p in profiles
            ]
    result["load_average_after"] = os.getloadavg()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2) + "\n")
    print(markdown(result))
    print(
        f"\nload average before {result['load_average_before'][0]:.2f}, "
        f"after {result['load_average_after'][0]:.2f}; raw figures: {args.out}"
    )


if __name__ == "__main__":
    main()
