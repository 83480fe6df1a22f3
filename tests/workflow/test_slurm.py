"""A calibration and a sampling campaign through profiles/slurm against a real SLURM (CI:
.ci/slurm/start.sh).

Runs only with DEMCAL_SLURM set (``.ci/run`` sets it after starting SLURM);
then it never skips: a SLURM that is down or misconfigured fails the test.

    .ci/slurm/start.sh && DEMCAL_SLURM=1 python -m pytest -q -m slurm
"""

import copy
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from helpers import ANALYTIC_STUDY, ROOT, demcal, evaluations, finish, study

pytestmark = [
    pytest.mark.slurm,
    pytest.mark.slow,  # a whole calibration through SLURM (up to TIME_LIMIT_S)
    pytest.mark.skipif(
        not os.environ.get("DEMCAL_SLURM"),
        reason="needs a SLURM: set DEMCAL_SLURM=1 after .ci/slurm/start.sh",
    ),
]

EVALUATIONS = 8
# The analytic engine's optimum is objective 0 (tests/daemon/test_daemon.py true_targets).
# Seed 5's initial design already holds a point at 8.2e-4; 2e-3 means the
# responses are within about 3 % of the targets, as in the local calibration test.
TOLERANCE = 2e-3
TIME_LIMIT_S = 170  # the whole calibration: 8 one-second simulations, two at a time


def slurm(*args: str, limit: int = 30) -> str:
    """Output of a SLURM client command; a failing command fails the test."""
    result = subprocess.run(
        ["timeout", "-k", "10", str(limit), *args],
        capture_output=True,
        text=True,
        stdin=subprocess.DEVNULL,
    )
    assert result.returncode == 0, f"{' '.join(args)} failed: {result.stderr.strip()}"
    return result.stdout


def finished_jobs_in(workdir: Path) -> dict[str, str]:
    """Job id -> state of the finished SLURM jobs started in ``workdir``, from the job record.

    start.sh configures jobcomp/filetxt (there is no accounting database);
    ``sacct -c`` reads that record.
    """
    out = slurm("sacct", "-c", "-n", "-P", "-o", "JobID,State,WorkDir")
    jobs = {}
    for line in out.splitlines():
        job, state, jobdir = (line.split("|") + ["", "", ""])[:3]
        if jobdir.rstrip("/") == str(workdir):
            jobs[job] = state
    return jobs


def test_calibration_runs_its_simulations_as_slurm_jobs(tmp_path):
    slurm("sinfo", "-h", "-o", "%P %a %D")  # SLURM answers at all
    config = study(
        tmp_path,
        "slurm",
        engine={"duration": 1.0},
        optimizer={"max_evaluations": EVALUATIONS, "early_termination": {"enabled": False}},
        calibration={"workers": 2, "poll_seconds": 0.5},
    )
    command = [
        "timeout",
        "-k",
        "30",
        str(TIME_LIMIT_S),
        sys.executable,
        "-m",
        "snakemake",
        "-s",
        ROOT / "Snakefile",
        f"--configfile={config}",
        "--profile",
        ROOT / "profiles" / "slurm",
        "results/slurm/finished.json",
    ]
    proc = subprocess.run(
        list(map(str, command)),
        cwd=tmp_path,
        capture_output=True,
        text=True,
        stdin=subprocess.DEVNULL,
        timeout=TIME_LIMIT_S + 60,
    )
    if proc.returncode != 0:  # stop evaluations a killed daemon left running
        demcal(tmp_path, "stop", config).communicate(timeout=60)
    assert proc.returncode == 0, (
        f"snakemake exit {proc.returncode} (124: over {TIME_LIMIT_S} s)\n{proc.stderr[-4000:]}"
    )
    assert (
        f"evaluation budget reached ({EVALUATIONS} of {EVALUATIONS})" in proc.stdout + proc.stderr
    )

    table = evaluations(tmp_path, "slurm")
    assert len(table) == EVALUATIONS
    assert set(table["status"]) <= {"ok", "terminated"}, table[["evaluation", "status", "reason"]]
    best = json.loads((tmp_path / "results/slurm/best.json").read_text())
    assert best["objective"] < TOLERANCE, best

    # every simulation was a SLURM job that completed, started from this directory
    jobs = finished_jobs_in(tmp_path)
    simulations = len(
        list((tmp_path / "results/slurm/evals").glob("*/cylinder_lift/rep0/simulation.json"))
    )
    assert simulations == EVALUATIONS
    assert len(jobs) == simulations and set(jobs.values()) == {"COMPLETED"}, jobs
    # each extracted in the simulation's own SLURM job (group "run"), archived here
    evals = tmp_path / "results/slurm/evals"
    logs = list(evals.glob("*/logs/extract_cylinder_lift_rep0.log"))
    assert len(logs) == EVALUATIONS
    for log in logs:
        assert "extract job on" in log.read_text() and "SLURM job" in log.read_text(), log
    assert len(list(evals.glob("*/archived"))) == EVALUATIONS
    archived = finish(demcal(tmp_path, "archive", "list", "--of", "slurm")).splitlines()
    assert len(archived) == EVALUATIONS


@pytest.mark.parametrize("bundle, slurm_jobs", [(1, 4), (2, 2)])
def test_a_campaign_runs_its_simulations_as_slurm_jobs(tmp_path, bundle, slurm_jobs):
    """demcal sample --profile profiles/slurm: every point of the design a SLURM job (with
    --bundle 2, two points a job), every simulation archived."""
    config = {**copy.deepcopy(ANALYTIC_STUDY), "study": "campaign", "replicates": 1}
    (tmp_path / "campaign.yaml").write_text(yaml.safe_dump(config))
    run = demcal(
        tmp_path,
        "sample",
        "campaign.yaml",
        "--points",
        "4",
        "--profile",
        str(ROOT / "profiles/slurm"),
        "--bundle",
        str(bundle),
    )
    out = finish(run, timeout=TIME_LIMIT_S)
    assert "4 of 4 simulations finished (4 ok)" in out
    assert len(finish(demcal(tmp_path, "archive", "list", "--of", "campaign")).splitlines()) == 4
    jobs = finished_jobs_in(tmp_path)
    assert len(jobs) == slurm_jobs and set(jobs.values()) == {"COMPLETED"}, jobs
    asked = slurm("sacct", "-c", "-n", "-P", "-o", "JobID,NCPUS,Timelimit").splitlines()
    for job, cpus, minutes in (line.split("|") for line in asked):
        if job in jobs:  # one core, the simulations' time limits (30 + 5 min each) added
            assert (int(cpus), int(minutes)) == (1, 35 * bundle), (job, cpus, minutes)
