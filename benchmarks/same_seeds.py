"""Same seeds, same result: a checkout's results at fixed seeds, compared before and after.

    python benchmarks/same_seeds.py run --root /work/base --out /work/baseline
    python benchmarks/same_seeds.py run --root /work/main --out /work/after
    python benchmarks/same_seeds.py compare /work/baseline /work/after [--across-format-1]

``run`` drives the checkout at ``--root`` only through its user interface,
with the checkout's own venv (``ROOT/.venv/bin/demcal`` and
``ROOT/.venv/bin/python -m snakemake``), so it works unchanged whatever the
package's inner layout. Every run happens in a fresh scratch folder (under
``--out``/scratch, deleted afterwards unless ``--keep-scratch``): nothing is
written into the checkout. What it runs:

A. analytic: ``config/examples/analytic.yaml`` as it is (seed 7, 2 replicates,
   30 evaluations, 1 % noise, 2 s fake run time), except one worker
   (``demcal run study.yaml --workers 1``) and early termination off
   (``optimizer.early_termination.enabled: false``, written into the scratch
   copy of the YAML). About 8 minutes (Snakemake's start-up per evaluation).
B. lammps: each lab test (cylinder_lift, shear_box, calibration_device) at the
   centre of its bounds, one tiny LAMMPS run per replicate with the scene's
   tiny settings (``TINY_SETTINGS`` of ``demcal.scenes.<scene>``, those of the
   tests, taken from the demcal this script runs with, so the same for every
   checkout compared): a tiny study YAML per scene and
   ``snakemake -s ROOT/Snakefile --profile ROOT/profiles/local
   --configfile=tiny.yaml evaluate_centre``. Seconds per simulation.

Collected into ``--out`` (one JSON file per source file, values kept as their
JSON/CSV text so that floats compare bit for bit):

- A: ``results/<study>/evaluations.csv``, ``best.json``, ``finished.json``,
  every ``evals/<id>/objective.json`` and ``params.json``;
- B: every ``evals/centre/<scene>/rep<r>/responses.json``, the centre's
  ``params.json`` and ``objective.json``.

Fields dropped, because they are measured times or timestamps (they differ
from run to run by nature; nothing else is dropped):

- evaluations.csv columns ``started_at``, ``ended_at`` (UTC launch and end
  time), ``wall_s`` (wall clock from launch to objective), ``cpu_s`` (CPU time
  of the simulations) -- see results/<study>/evaluations.columns.csv;
- objective.json ``cost.cpu_s`` and ``cost.simulation_wall_s``;
- responses.json ``cost.cpu_s``, ``cost.wall_s`` and (LAMMPS) ``cost.worker_cpu_s``, the
  worker's CPU time; ``cost.steps``, ``particle_steps``, ``timestep_s``,
  ``rayleigh_time_s`` and ``simulated_time_s`` are simulation quantities and kept;
- finished.json ``ended_at``.

Any key with one of the names in :data:`TIME_KEYS` is dropped at any depth
of a JSON file. ``timestep_cost`` in objective.json is a penalty computed from
the parameters, not a time, and is kept.

``compare`` prints, per file, identical or differs (the first differing field
and both values), and files only on one side; it exits 1 if anything differs.
Numbers compare as their text (``0.1`` vs ``0.10000000000000001`` differs);
the order of keys in a JSON object and of columns in the CSV does not count.
"""

from __future__ import annotations

import argparse
import csv
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

from demcal.scenes import calibration_device, cylinder_lift, shear_box

#: Keys (JSON) and columns (evaluations.csv) dropped: measured times and timestamps.
TIME_KEYS = frozenset(
    {"started_at", "ended_at", "wall_s", "cpu_s", "simulation_wall_s", "worker_cpu_s"}
)

ANALYTIC_YAML = "config/examples/analytic.yaml"

COMMON_FIXED = {"youngs_modulus": 5.0e6, "poisson_ratio": 0.3, "restitution_pp": 0.5}

#: One tiny study per lab test: the scene's tiny settings (its ``TINY_SETTINGS``, those of the
#: tests), the examples' parameters and targets.
TINY_STUDIES = {
    "cylinder_lift": {
        "settings": cylinder_lift.TINY_SETTINGS,
        "parameters": {
            "sliding_friction_pp": {"lower": 0.1, "upper": 0.9},
            "rolling_friction_pp": {"lower": 0.02, "upper": 0.3},
        },
        "fixed": {**COMMON_FIXED, "particle_density": 2500.0},
        "targets": [
            {"response": "angle_of_repose", "value": 25.0, "unit": "deg", "spread": 1.5},
            {"response": "bulk_density", "value": 1450.0, "unit": "kg/m^3", "spread": 4.3},
        ],
        "seed": 7,
    },
    "shear_box": {
        "settings": shear_box.TINY_SETTINGS,
        "parameters": {
            "sliding_friction_pp": {"lower": 0.1, "upper": 0.9},
            "particle_density": {"lower": 2000.0, "upper": 3000.0, "unit": "kg/m^3"},
        },
        "fixed": {**COMMON_FIXED, "rolling_friction_pp": 0.1},
        "targets": [
            {"response": "shear_angle", "value": 25.65, "unit": "deg", "spread": 1.14},
            {"response": "bulk_density", "value": 1445.0, "unit": "kg/m^3", "spread": 3.3},
        ],
        "seed": 7,
    },
    "calibration_device": {
        "settings": calibration_device.TINY_SETTINGS,
        "parameters": {
            "sliding_friction_pp": {"lower": 0.2, "upper": 0.9},
            "sliding_friction_pw": {"lower": 0.2, "upper": 0.9},
        },
        "fixed": {**COMMON_FIXED, "rolling_friction_pp": 0.1, "particle_density": 2750.0},
        "targets": [
            {"response": "mass_flow", "value": 0.0541, "unit": "kg/s", "spread": 0.0012},
            {"response": "slide_time", "value": 0.567, "unit": "s", "spread": 0.006},
            {"response": "angle_of_repose", "value": 10.46, "unit": "deg", "spread": 0.7},
        ],
        "seed": 3,
    },
}
TINY_REPLICATES = 2


# -- running ------------------------------------------------------------------


def _run(command: list[str], cwd: Path, log: Path) -> float:
    """Run a command in cwd with its output in log; its wall time [s]. Exits on failure."""
    start = time.monotonic()
    with open(log, "w") as out:
        done = subprocess.run(command, cwd=cwd, stdout=out, stderr=subprocess.STDOUT)
    seconds = time.monotonic() - start
    if done.returncode != 0:
        sys.exit(
            f"same_seeds: {' '.join(command)} (in {cwd}) failed with exit code "
            f"{done.returncode}; see {log}"
        )
    return seconds


def _fresh(folder: Path) -> Path:
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    return folder


def _read_yaml(root: Path, path: Path) -> dict:
    """A YAML file read by the checkout's venv (PyYAML comes with Snakemake), as plain data."""
    code = "import json, sys, yaml; print(json.dumps(yaml.safe_load(open(sys.argv[1]))))"
    done = subprocess.run(
        [str(root / ".venv" / "bin" / "python"), "-c", code, str(path)],
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(done.stdout)


def run_analytic(root: Path, scratch: Path, out: Path) -> float:
    study = _read_yaml(root, root / ANALYTIC_YAML)
    study.setdefault("optimizer", {})["early_termination"] = {"enabled": False}
    (scratch / "study.yaml").write_text(json.dumps(study, indent=1) + "\n")  # JSON is YAML
    demcal = root / ".venv" / "bin" / "demcal"
    seconds = _run(
        [str(demcal), "run", "study.yaml", "--workers", "1"], scratch, out / "analytic.log"
    )
    results = scratch / "results" / study["study"]
    target = out / "analytic"
    collect(results / "evaluations.csv", target / "evaluations.csv.json")
    for name in ("best.json", "finished.json"):
        collect(results / name, target / name)
    evaluations = sorted(p for p in (results / "evals").iterdir() if p.is_dir())
    if not evaluations:
        sys.exit(f"same_seeds: no evaluations in {results / 'evals'}")
    for folder in evaluations:
        for name in ("objective.json", "params.json"):
            collect(folder / name, target / "evals" / folder.name / name)
    return seconds


def tiny_study(scene: str) -> dict:
    spec = TINY_STUDIES[scene]
    return {
        "study": f"tiny-{scene.replace('_', '-')}",
        "engine": {"name": "lammps"},
        "scenes": {scene: {"settings": spec["settings"]}},
        "parameters": spec["parameters"],
        "fixed": spec["fixed"],
        "targets": [{"scene": scene, **t} for t in spec["targets"]],
        "replicates": TINY_REPLICATES,
        "seed": spec["seed"],
        "timestep_fraction": 0.25,
        "objective": "relative",
    }


def run_lammps(root: Path, scratch: Path, out: Path, scene: str) -> float:
    study = tiny_study(scene)
    (scratch / "tiny.yaml").write_text(json.dumps(study, indent=1) + "\n")  # JSON is YAML
    python = root / ".venv" / "bin" / "python"
    command = [
        str(python),
        "-m",
        "snakemake",
        "-s",
        str(root / "Snakefile"),
        "--profile",
        str(root / "profiles" / "local"),
        "--configfile=tiny.yaml",  # "=": --configfile takes several files
        "evaluate_centre",
    ]
    seconds = _run(command, scratch, out / f"lammps_{scene}.log")
    centre = scratch / "results" / study["study"] / "evals" / "centre"
    target = out / "lammps" / scene
    for name in ("params.json", "objective.json"):
        collect(centre / name, target / name)
    for replicate in range(TINY_REPLICATES):
        collect(
            centre / scene / f"rep{replicate}" / "responses.json",
            target / f"rep{replicate}" / "responses.json",
        )
    return seconds


def collect(source: Path, target: Path) -> None:
    """source (JSON, or evaluations.csv as a list of rows) without its time fields, as JSON."""
    if not source.is_file():
        sys.exit(f"same_seeds: {source} missing")
    if source.suffix == ".csv":
        with open(source, newline="") as f:
            rows = [
                {k: v for k, v in row.items() if k not in TIME_KEYS} for row in csv.DictReader(f)
            ]
        data = {"columns": [c for c in rows[0] if c not in TIME_KEYS] if rows else [], "rows": rows}
    else:
        data = _drop_times(
            json.loads(
                source.read_text(), parse_float=_Number, parse_int=_Number, parse_constant=_Number
            )
        )
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(json.dumps(data, indent=1, sort_keys=True, default=str) + "\n")


class _Number(str):
    """A JSON number kept as its text (written back as a string: compared exactly)."""


def _drop_times(value):
    if isinstance(value, dict):
        return {k: _drop_times(v) for k, v in value.items() if k not in TIME_KEYS}
    if isinstance(value, list):
        return [_drop_times(v) for v in value]
    return value


def run(args) -> int:
    root, out = Path(args.root).resolve(), Path(args.out).resolve()
    if not (root / ".venv" / "bin" / "demcal").is_file():
        sys.exit(f"same_seeds: {root}/.venv/bin/demcal missing: give the checkout its venv first")
    out.mkdir(parents=True, exist_ok=True)
    for part in ("analytic", "lammps"):
        if part in args.parts and (out / part).exists():
            shutil.rmtree(out / part)
    scratch_root = out / "scratch"
    commit = subprocess.run(
        ["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True
    ).stdout.strip()
    git_status = ["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"]
    dirty = subprocess.run(git_status, capture_output=True, text=True).stdout.strip()
    timings = {}
    if "lammps" in args.parts:
        for scene in args.scenes:
            scratch = _fresh(scratch_root / f"lammps_{scene}")
            timings[f"lammps_{scene}"] = run_lammps(root, scratch, out, scene)
            print(f"same_seeds: lammps {scene}: {timings[f'lammps_{scene}']:.0f} s", flush=True)
    if "analytic" in args.parts:
        scratch = _fresh(scratch_root / "analytic")
        timings["analytic"] = run_analytic(root, scratch, out)
        print(f"same_seeds: analytic: {timings['analytic']:.0f} s", flush=True)
    if not args.keep_scratch:
        shutil.rmtree(scratch_root)
    (out / "run.json").write_text(
        json.dumps(
            {
                "root": str(root),
                "commit": commit,
                "uncommitted_changes": bool(dirty),
                "wall_seconds": {k: round(v, 1) for k, v in timings.items()},
            },
            indent=1,
        )
        + "\n"
    )
    changes = ", with uncommitted changes" if dirty else ""
    print(f"same_seeds: {root} (commit {commit[:10]}{changes}) -> {out}")
    return 0


# -- comparing ----------------------------------------------------------------


def first_difference(a, b, where: str = "") -> tuple[str, object, object] | None:
    """The first place where a and b differ (path, value a, value b), or None."""
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            here = f"{where}.{key}" if where else key
            if key not in a or key not in b:
                return here, a.get(key, "<missing>"), b.get(key, "<missing>")
            found = first_difference(a[key], b[key], here)
            if found:
                return found
        return None
    if isinstance(a, list) and isinstance(b, list):
        for i, (x, y) in enumerate(zip(a, b)):
            found = first_difference(x, y, f"{where}[{i}]")
            if found:
                return found
        if len(a) != len(b):
            return f"{where} (length)", len(a), len(b)
        return None
    if type(a) is not type(b) or a != b:
        return where or "<whole file>", a, b
    return None


def _rows_by_evaluation(data):
    """evaluations.csv: rows keyed by evaluation id, columns as a set (order does not count)."""
    if isinstance(data, dict) and "rows" in data and "columns" in data:
        return {
            "columns": sorted(data["columns"]),
            "rows": {row.get("evaluation", str(i)): row for i, row in enumerate(data["rows"])},
            "row_order": [row.get("evaluation", str(i)) for i, row in enumerate(data["rows"])],
        }
    return data


#: What format 1 of the records (issue 19, demcal/results/records.py) changed on purpose:
#: every record names its format; objective.json names the objective it was scored with
#: (scored_with) instead of copying the targets, weights and form; an absent optional field
#: and an empty one (null, {}, [], "") are the same record.
FORMAT_1_ADDED = frozenset({"format", "scored_with"})
FORMAT_1_MOVED = {"objective.json": frozenset({"targets", "weights", "objective_form"})}


def across_format_1(data, name: str):
    """A collected file with format 1's intended changes taken out (``--across-format-1``)."""
    if not isinstance(data, dict) or "rows" in data:
        return data
    moved = FORMAT_1_MOVED.get(Path(name).name, frozenset())

    def empty(value) -> bool:
        return value is None or value == {} or value == [] or value == ""

    def clean(value, top: bool):
        if isinstance(value, dict):
            return {
                k: clean(v, False)
                for k, v in value.items()
                if not (top and (k in FORMAT_1_ADDED or k in moved)) and not empty(v)
            }
        return value

    return clean(data, True)


def compare(args) -> int:
    before, after = Path(args.before), Path(args.after)
    files = sorted(
        {
            p.relative_to(d)
            for d in (before, after)
            for p in d.rglob("*.json")
            if p.name != "run.json" and "scratch" not in p.relative_to(d).parts
        }
    )
    if not files:
        sys.exit(f"same_seeds: no collected files in {before} or {after}")
    differ = 0
    for name in files:
        a, b = before / name, after / name
        if not a.exists() or not b.exists():
            differ += 1
            print(f"{name}: only in {before if a.exists() else after}")
            continue
        x, y = json.loads(a.read_text()), json.loads(b.read_text())
        if args.across_format_1:
            x, y = across_format_1(x, str(name)), across_format_1(y, str(name))
        found = first_difference(_rows_by_evaluation(x), _rows_by_evaluation(y))
        if found is None:
            print(f"{name}: identical")
        else:
            differ += 1
            field, x, y = found
            print(f"{name}: differs at {field}: {x!r} != {y!r}")
    print(
        f"same_seeds: {len(files) - differ} of {len(files)} files identical"
        + (f", {differ} differ" if differ else "")
    )
    return 1 if differ else 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)
    r = commands.add_parser("run", help="run a checkout at fixed seeds and collect its results")
    r.add_argument("--root", required=True, help="the checkout (with its own .venv)")
    r.add_argument("--out", required=True, help="folder for the collected results")
    r.add_argument(
        "--parts", nargs="+", choices=("analytic", "lammps"), default=["analytic", "lammps"]
    )
    r.add_argument("--scenes", nargs="+", choices=tuple(TINY_STUDIES), default=list(TINY_STUDIES))
    r.add_argument("--keep-scratch", action="store_true", help="keep the run folders (OUT/scratch)")
    r.set_defaults(func=run)
    c = commands.add_parser("compare", help="compare two collected result folders")
    c.add_argument("before")
    c.add_argument("after")
    c.add_argument(
        "--across-format-1",
        action="store_true",
        help="before is older than the records' format 1: leave out its intended changes "
        "(FORMAT_1_ADDED, FORMAT_1_MOVED, absent = empty)",
    )
    c.set_defaults(func=compare)
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
