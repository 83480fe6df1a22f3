"""Every results file of an evaluation has one writer, its job, also when the daemon takes the
evaluation before the evaluation's child Snakemake has ended (issue 37, item 2).

Snakemake records which job wrote each output (``.snakemake/metadata``: the rule, and the
file's modification time when the job ended); a file the daemon wrote has no such record, and
one written again since has another time.
"""

import base64
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from helpers import evaluations, study

from demcal.results.layout import StudyFiles

#: Seconds a child Snakemake is held stopped once its last simulation is being extracted: the
#: daemon takes the evaluation meanwhile, as it does through SLURM while the executor's next
#: status check (10 s to 3 min away) has not yet told the child that its jobs have ended.
HOLD_S = 15.0

#: Children held, at most: the first whose last extraction is caught under way.
HELD = 3


def started_by(pid: int) -> list[str]:
    """Command lines of the processes that ``pid`` started (a Snakemake's jobs)."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            if int(stat.read_text().rsplit(")", 1)[1].split()[1]) == pid:
                found.append((stat.parent / "cmdline").read_bytes().decode(errors="replace"))
        except (OSError, IndexError, ValueError):
            continue  # ended meanwhile
    return found


def signal_child(pid: int, signum: int) -> None:
    try:
        os.kill(pid, signum)
    except ProcessLookupError:
        pass


def hold_in_extraction(files, replicates: int) -> int | None:
    """Stop an evaluation's child Snakemake while the job that writes its last responses.json
    runs (the job goes on; the Snakemake starts nothing more); its pid, or None."""
    responses = [files.replicate("cylinder_lift", r).responses for r in range(replicates)]
    try:
        pid = json.loads(files.launch.read_text())["pid"]
    except (OSError, ValueError, KeyError):
        return None
    missing = [path for path in responses if not path.exists()]
    if len(missing) != 1 or not missing[0].with_name("simulation.json").exists():
        return None  # not the last simulation's extraction
    if not any(command.endswith(".extract.py\0") for command in started_by(pid)):
        return None
    signal_child(pid, signal.SIGSTOP)
    if any(".objective.py" in command for command in started_by(pid)):
        signal_child(pid, signal.SIGCONT)  # too late: its last jobs are under way
        return None
    return pid


def job_records(folder: Path, kind: str) -> dict[str, Path]:
    """Snakemake's records in ``.snakemake/<kind>`` (metadata, incomplete), by output path."""
    root = folder / ".snakemake" / kind
    records = root.rglob("*") if root.is_dir() else []
    return {base64.urlsafe_b64decode(p.name).decode(): p for p in records if p.is_file()}


@pytest.mark.slow
def test_each_results_file_has_one_writer_when_results_are_taken_early(tmp_path, monkeypatch):
    """A calibration with early termination and staged replicates, some children held (as
    SLURM holds them) while the daemon takes their evaluations: every simulation.json,
    responses.json, released, objective.json and archive mark was written by its job, once,
    and the children held wrote their objective.json after they went on."""
    replicates = 2
    config = study(
        tmp_path,
        "writers",
        engine={"duration": 3.0, "chunks": 30},
        replicates=replicates,
        staging="staged",
        optimizer={
            "max_evaluations": 10,
            "early_termination": {"thresholds": [1.0], "progress_boundaries": []},
        },
    )
    monkeypatch.chdir(tmp_path)
    files = StudyFiles.of("writers")
    with open(tmp_path / "run.log", "w") as out:
        daemon = subprocess.Popen(
            [sys.executable, "-m", "demcal.cli", "run", str(config)],
            stdin=subprocess.DEVNULL,
            stdout=out,
            stderr=subprocess.STDOUT,
        )
    stopped: dict[str, tuple[int, float]] = {}  # evaluation: (its child's pid, since)
    went_on: dict[str, float] = {}  # evaluation: when its child went on (Unix s)
    deadline = time.monotonic() + 600
    while daemon.poll() is None:
        assert time.monotonic() < deadline, "the calibration did not end"
        for evaluation, (pid, since) in list(stopped.items()):
            if time.monotonic() - since > HOLD_S:
                went_on[evaluation] = time.time()
                signal_child(pid, signal.SIGCONT)
                del stopped[evaluation]
        for evaluation in files.evaluations():
            if len(stopped) + len(went_on) >= HELD:
                break
            if evaluation.id not in stopped and evaluation.id not in went_on:
                pid = hold_in_extraction(evaluation, replicates)
                if pid is not None:
                    stopped[evaluation.id] = (pid, time.monotonic())
        time.sleep(0.02)
    assert daemon.returncode == 0, (tmp_path / "run.log").read_text()[-3000:]
    assert went_on and not stopped

    table = evaluations(tmp_path, "writers")
    assert set(table["status"]) == {"ok", "terminated"}  # early termination stopped some
    writers: dict[Path, str] = {}
    for evaluation in files.evaluations():
        writers[evaluation.objective] = "objective"
        writers[evaluation.archived] = "archive"
        for replicate in range(replicates):
            run = evaluation.replicate("cylinder_lift", replicate)
            writers[run.simulation] = "simulate"
            writers[run.responses] = "extract"
            if run.released.exists():
                writers[run.released] = "release"
    assert any(rule == "release" for rule in writers.values())  # staged evaluations ran
    records = job_records(tmp_path, "metadata")
    for path, rule in writers.items():
        assert str(path) in records, f"{path}: not written by a job of the workflow"
        record = json.loads(records[str(path)].read_text())
        assert (record["rule"], record["incomplete"]) == (rule, False), path
        assert record["endtime"] == path.stat().st_mtime, f"{path}: written again after its job"
    # no job wrote anything else (params.json, launch.json, STOP are the daemon's)
    assert {p for p in records if p.startswith(f"{files.dir}/")} == {str(p) for p in writers}
    assert not job_records(tmp_path, "incomplete")
    for evaluation, when in went_on.items():
        assert files.evaluation(evaluation).objective.stat().st_mtime >= when, evaluation
