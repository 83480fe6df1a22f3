"""The Snakemake command lines demcal starts (demcal.snakemake_command): where SLURM's client is
installed but no controller answers, a run on local cores sees no SLURM configuration, so that
the SLURM plugin's question to the controller fails at once instead of after 10 s."""

from __future__ import annotations

import os
import subprocess

import pytest

from demcal import snakemake_command

NO_SLURM = ["env", f"SLURM_CONF={os.devnull}"]


@pytest.fixture
def slurm_client(monkeypatch):
    """A SLURM client whose ``scontrol ping`` ends with the (code, output) set in
    ``state["ping"]`` (None: it hangs past the limit); counts the pings."""
    state = {"ping": (1, ""), "pings": 0}

    def run(command, **kwargs):
        assert command == ["scontrol", "ping"]
        state["pings"] += 1
        if state["ping"] is None:
            raise subprocess.TimeoutExpired(command, kwargs["timeout"])
        code, output = state["ping"]
        return subprocess.CompletedProcess(command, code, output, "")

    monkeypatch.setattr(snakemake_command.shutil, "which", lambda name: f"/usr/bin/{name}")
    monkeypatch.setattr(snakemake_command.subprocess, "run", run)
    monkeypatch.delenv("SLURM_JOB_ID", raising=False)
    snakemake_command.slurm_unreachable.cache_clear()
    yield state
    snakemake_command.slurm_unreachable.cache_clear()


@pytest.mark.parametrize(
    "ping", [(1, ""), (0, "Slurmctld(primary) at vm is DOWN")], ids=["failed", "says_down"]
)
def test_a_local_run_sees_no_slurm_where_no_controller_answers(slurm_client, ping):
    slurm_client["ping"] = ping
    child = snakemake_command.child_command("study.json", "objective.json", None, None)
    assert child[:2] == NO_SLURM and child[3:5] == ["-m", "snakemake"]
    assert snakemake_command.report_command("study.json", "report.html")[:2] == NO_SLURM
    assert slurm_client["pings"] == 1  # asked once per process


def test_slurm_runs_and_controllers_that_may_answer_are_left_alone(slurm_client, monkeypatch):
    slurm = snakemake_command.PROFILES_DIR / "slurm"
    assert (
        snakemake_command.child_command("study.json", "objective.json", slurm, None)[:2] != NO_SLURM
    )
    for ping in [(0, "Slurmctld(primary) at vm is UP"), None]:  # up, or too slow to say
        slurm_client["ping"] = ping
        snakemake_command.slurm_unreachable.cache_clear()
        assert (
            snakemake_command.child_command("study.json", "objective.json", None, None)[:2]
            != NO_SLURM
        )
    slurm_client["ping"] = (1, "")
    monkeypatch.setenv("SLURM_JOB_ID", "42")  # inside an allocation: srun must keep working
    snakemake_command.slurm_unreachable.cache_clear()
    assert (
        snakemake_command.child_command("study.json", "objective.json", None, None)[:2] != NO_SLURM
    )


def test_without_a_slurm_client_nothing_is_asked(monkeypatch):
    monkeypatch.setattr(snakemake_command.shutil, "which", lambda name: None)
    snakemake_command.slurm_unreachable.cache_clear()
    try:
        assert not snakemake_command.slurm_unreachable()
    finally:
        snakemake_command.slurm_unreachable.cache_clear()
