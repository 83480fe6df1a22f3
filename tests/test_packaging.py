"""demcal installed from a wheel (not editable) finds its workflow files and calibrates."""

import json
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest
import yaml

#: builds a wheel, installs it in a new venv and calibrates with it
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
#: What a source checkout holds beside the package: left out of the copy the wheel is built from
#: (at the top only: demcal/results/ is part of the package, results/ is a study's output).
TOP_LEVEL_ONLY = {".git", ".venv", "venv", "results", ".snakemake", "build", "benchmarks"}
ANYWHERE = shutil.ignore_patterns("*.egg-info", "__pycache__", ".pytest_cache", ".mypy_cache")


def source_only(folder: str, names: list[str]) -> set[str]:
    ignored = set(ANYWHERE(folder, names))
    if Path(folder) == ROOT:
        ignored |= TOP_LEVEL_ONLY & set(names)
    return ignored


def run(*command, **kwargs):
    proc = subprocess.run(
        [str(c) for c in command],
        capture_output=True,
        text=True,
        stdin=subprocess.DEVNULL,
        timeout=600,
        **kwargs,
    )
    assert proc.returncode == 0, (proc.stdout[-2000:], proc.stderr[-3000:])
    return proc


def test_wheel_install_runs_the_analytic_example(tmp_path):
    source = tmp_path / "source"
    shutil.copytree(ROOT, source, ignore=source_only)
    run(
        sys.executable,
        "-m",
        "pip",
        "wheel",
        "-q",
        "--no-deps",
        "--no-build-isolation",
        "-w",
        tmp_path / "dist",
        source,
    )
    wheel = next((tmp_path / "dist").glob("demcal-*.whl"))
    venv = tmp_path / "venv"
    run(sys.executable, "-m", "venv", venv)
    python = venv / "bin" / "python"
    site = Path(
        run(
            python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"
        ).stdout.strip()
    )
    # demcal's dependencies come from the test's environment; demcal itself only from the wheel
    (site / "demcal_test_dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    run(python, "-m", "pip", "install", "-q", "--no-deps", "--no-index", wheel)

    work = tmp_path / "work"
    work.mkdir()
    config = yaml.safe_load((ROOT / "config/examples/analytic.yaml").read_text())
    config["optimizer"] = {**config.get("optimizer", {}), "max_evaluations": 4}
    (work / "analytic.yaml").write_text(yaml.safe_dump(config))
    where = run(python, "-c", "import demcal.resources as r; print(r.PROJECT_ROOT)", cwd=work)
    assert Path(where.stdout.strip()).is_relative_to(site)  # the wheel's copy, not the source
    out = run(venv / "bin" / "demcal", "run", "analytic.yaml", cwd=work).stdout
    assert "evaluation budget reached (4 of 4)" in out
    results = work / "results" / config["study"]
    assert json.loads((results / "finished.json").read_text())["evaluations"] == {"ok": 4}
    assert json.loads((results / "study.json").read_text())["demcal_version"] == "0.1.0"
    # the archive's migrations travel in the wheel: its jobs recorded every simulation
    stats = run(venv / "bin" / "demcal", "archive", "stats", cwd=work).stdout
    assert f"{config['study']} cylinder_lift analytic ok: 8 " in stats
