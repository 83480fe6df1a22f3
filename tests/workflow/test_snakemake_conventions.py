"""Snakemake's own conventions on demcal's workflow, through the README's route
(``snakemake --profile profiles/local --configfile=FILE``): a dry run lists the jobs and
what the calibration would do, graphs draw an evaluation's jobs, and neither starts or
writes anything outside .snakemake/."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from itertools import takewhile
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "config" / "examples" / "analytic.yaml"
PLAN = (
    "demcal: calibrate study 'analytic-demo': up to 30 evaluations x 1 scene (cylinder_lift) "
    "x 2 replicates of simulate -> extract -> objective"
)


def snakemake(folder: Path, *args: str) -> subprocess.CompletedProcess:
    """The README's command on the analytic example copied into ``folder``, with ``args``."""
    if not (folder / "analytic.yaml").exists():
        shutil.copyfile(EXAMPLE, folder / "analytic.yaml")
    return subprocess.run(
        [sys.executable, "-m", "snakemake", "-s", str(ROOT / "Snakefile")]
        + ["--profile", str(ROOT / "profiles" / "local"), "--configfile=analytic.yaml", *args],
        cwd=folder,
        capture_output=True,
        text=True,
        timeout=300,
        stdin=subprocess.DEVNULL,
    )


def written(folder: Path) -> set[str]:
    """What is in ``folder`` besides Snakemake's own .snakemake/."""
    return {
        str(path.relative_to(folder))
        for path in folder.rglob("*")
        if path.relative_to(folder).parts[0] != ".snakemake"
    }


@pytest.mark.slow
def test_a_dry_run_lists_the_jobs_and_the_plan_and_starts_nothing(tmp_path):
    proc = snakemake(tmp_path, "-n")
    assert proc.returncode == 0, proc.stderr[-3000:]
    text = proc.stdout + proc.stderr
    assert "Job stats:" in text and "This was a dry-run (flag -n)" in text
    for rule in ("calibrate", "plots", "solutions", "evaluation_dag"):
        assert re.search(rf"^{rule}\s+1$", text, re.MULTILINE), rule
    assert PLAN in text
    assert "Traceback" not in text
    assert written(tmp_path) == {"analytic.yaml"}  # no results/, no evals, no study.json


@pytest.mark.slow
def test_a_dry_run_sees_what_a_run_would_do_to_an_existing_study(tmp_path):
    """Finished: the calibration is not listed; a larger budget lists it again; a change a run
    would refuse is refused in one line. The study's own files are never touched."""
    from demcal.study.config import load_study
    from demcal.study.model import freeze
    from demcal.study.study_file import read_study_yaml

    shutil.copyfile(EXAMPLE, tmp_path / "analytic.yaml")
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(tmp_path)
        freeze(load_study(read_study_yaml("analytic.yaml")))
    study = tmp_path / "results" / "analytic-demo"
    (study / "finished.json").write_text(json.dumps({"reason": "evaluation budget reached"}))
    before = {path.name: (path.read_bytes(), path.stat().st_mtime_ns) for path in study.iterdir()}

    finished = snakemake(tmp_path, "-n")
    assert finished.returncode == 0, finished.stderr[-3000:]
    assert not re.search(r"^calibrate\s+1$", finished.stderr, re.MULTILINE)
    assert "Job stats:" in finished.stderr and PLAN not in finished.stderr

    config = yaml.safe_load(EXAMPLE.read_text())
    config["optimizer"]["max_evaluations"] = 40
    (tmp_path / "analytic.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    resumed = snakemake(tmp_path, "-n")
    assert resumed.returncode == 0, resumed.stderr[-3000:]
    assert re.search(r"^calibrate\s+1$", resumed.stderr, re.MULTILINE)
    assert "up to 40 evaluations" in resumed.stderr

    config["replicates"] = 3
    (tmp_path / "analytic.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    refused = snakemake(tmp_path, "-n")
    assert refused.returncode == 1
    assert "holds a calibration of a different study (replicates: 2 -> 3)" in refused.stderr
    assert "Traceback" not in refused.stderr
    after = {path.name: (path.read_bytes(), path.stat().st_mtime_ns) for path in study.iterdir()}
    assert after == before


def dot_edges(dot: str) -> set[tuple[str, str]]:
    """(from, to) rule names of the edges of Snakemake's DOT output."""
    names = {
        node: label.split("\\n")[0]
        for node, label in re.findall(r'^\s*(\d+)\[label = "([^"]*)"', dot, re.MULTILINE)
    }
    return {(names[a], names[b]) for a, b in re.findall(r"^\s*(\d+) -> (\d+)$", dot, re.MULTILINE)}


@pytest.mark.slow
@pytest.mark.parametrize("graph", ["--dag", "--rulegraph"])
def test_graphs_draw_the_jobs_of_an_evaluation_before_the_calibration(tmp_path, graph):
    proc = snakemake(tmp_path, graph)
    assert proc.returncode == 0, proc.stderr[-3000:]
    edges = dot_edges(proc.stdout)
    for edge in [
        ("simulate", "extract"),
        ("extract", "objective"),
        ("extract", "archive"),
        ("objective", "calibrate"),
        ("archive", "calibrate"),
        ("calibrate", "plots"),
        ("calibrate", "solutions"),
    ]:
        assert edge in edges, edge
    if graph == "--dag":  # one evaluation, both replicates of its scene
        assert proc.stdout.count('label = "simulate\\nevaluation: each\\n') == 2
    assert written(tmp_path) == {"analytic.yaml"}


SNAKEMAKE_COMMAND = re.compile(r"snakemake [^`\n]*--configfile(?!=)")


def header(path: Path) -> str:
    """The comment lines a study file opens with."""
    return "\n".join(takewhile(lambda line: line.startswith("#"), path.read_text().splitlines()))


def test_every_snakemake_command_shown_writes_configfile_with_the_equals_sign():
    """Snakemake reads every word after a bare --configfile as another config file."""
    headers = {path.name: header(path) for path in sorted((ROOT / "config").rglob("*.yaml"))}
    assert "--configfile=config/examples/analytic.yaml" in headers["analytic.yaml"]
    assert "--configfile=config/examples/joint_analytic.yaml" in headers["joint_analytic.yaml"]
    pages = {path.name: path.read_text() for path in [ROOT / "README.md", *ROOT.glob("docs/*.md")]}
    slips = [
        f"{name}: {match}"
        for name, text in {**headers, **pages}.items()
        for match in SNAKEMAKE_COMMAND.findall(text)
    ]
    assert slips == []


@pytest.mark.slow
def test_a_reopened_calibration_runs_again_on_the_readme_route(tmp_path):
    """demcal add-point, rerun-failed and solutions --explore reopen a finished calibration by
    removing finished.json; with every figure present, Snakemake said 'Nothing to be done'."""
    from demcal.study.config import load_study
    from demcal.study.model import freeze
    from demcal.study.study_file import read_study_yaml

    shutil.copyfile(EXAMPLE, tmp_path / "analytic.yaml")
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(tmp_path)
        finished = tmp_path / freeze(load_study(read_study_yaml("analytic.yaml"))).files.finished
    finished.write_text(json.dumps({"reason": "evaluation budget reached"}))
    summary = snakemake(tmp_path, "--summary")  # every output file, one per line
    assert summary.returncode == 0, summary.stderr[-3000:]
    figures = [line.split("\t")[0] for line in summary.stdout.splitlines() if "/plots/" in line]
    assert len(figures) >= 8, summary.stdout[-2000:]
    for figure in figures:  # drawn after the calibration finished, as a finished run leaves them
        (tmp_path / figure).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / figure).write_text("drawn")
    assert not re.search(r"^calibrate\s+1$", snakemake(tmp_path, "-n").stderr, re.MULTILINE)

    finished.unlink()  # what reopening does (demcal/daemon/control.py)
    reopened = snakemake(tmp_path, "-n")
    assert reopened.returncode == 0, reopened.stderr[-3000:]
    assert re.search(r"^calibrate\s+1$", reopened.stderr, re.MULTILINE), reopened.stderr[-3000:]
