"""The Snakemake command lines demcal starts (demcal.workflow): where SLURM's client is
installed but no controller answers, a run on local cores sees no SLURM configuration, so that
the SLURM plugin's question to the controller fails at once instead of after 10 s."""

from __future__ import annotations

import os
import subprocess

import pytest

from demcal import workflow

NO_SLURM = ["env", f"SLURM_CONF={os.devnull}"]


@pytest.fixture
def slurm_client(monkeypatch):
    """A SLURM client whose ``scontrol ping`` ends with the code set in ``state["ping"]``
    (None: it hangs past the limit); counts the pings."""
    state = {"ping": 1, "pings": 0}

    def run(command, **kwargs):
        assert command == ["scontrol", "ping"]
        state["pings"] += 1
        if state["ping"] is None:
            raise subprocess.TimeoutExpired(command, kwargs["timeout"])
        return subprocess.CompletedProcess(command, state["ping"], b"", b"")

    monkeypatch.setattr(workflow.shutil, "which", lambda name: f"/usr/bin/{name}")
    monkeypatch.setattr(workflow.subprocess, "run", run)
    workflow.slurm_unreachable.cache_clear()
    yield state
    workflow.slurm_unreachable.cache_clear()


@pytest.mark.parametrize("ping", [1, None], ids=["controller_down", "ping_hangs"])
def test_a_local_run_sees_no_slurm_where_no_controller_answers(slurm_client, ping):
    slurm_client["ping"] = ping
    child = workflow.child_command("study.json", "objective.json", None, None)
    assert child[:2] == NO_SLURM and child[3:5] == ["-m", "snakemake"]
    assert workflow.report_command("study.json", "report.html")[:2] == NO_SLURM
    assert slurm_client["pings"] == 1  # asked once per process


def test_slurm_runs_and_reachable_controllers_are_left_alone(slurm_client):
    slurm = workflow.PROFILES_DIR / "slurm"
    assert workflow.child_command("study.json", "objective.json", slurm, None)[:2] != NO_SLURM
    slurm_client["ping"] = 0
    workflow.slurm_unreachable.cache_clear()
    assert workflow.child_command("study.json", "objective.json", None, None)[:2] != NO_SLURM


def test_without_a_slurm_client_nothing_is_asked(monkeypatch):
    monkeypatch.setattr(workflow.shutil, "which", lambda name: None)
    workflow.slurm_unreachable.cache_clear()
    try:
        assert not workflow.slurm_unreachable()
    finally:
        workflow.slurm_unreachable.cache_clear()
