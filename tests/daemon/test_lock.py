"""The daemon lock: one holder per study, released when its process ends, however it ends.

The holder is a forked child of the test process (it has demcal imported already), not Snakemake.
"""

from __future__ import annotations

import json
import os
import signal
import time

import pytest
from helpers import analytic_example

from demcal.daemon.control import lock_study, running_daemon
from demcal.errors import DemcalError
from demcal.study.config import load_study


@pytest.fixture
def study(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return load_study(analytic_example())


def dead_pid() -> int:
    """The pid of a process that has ended and been reaped."""
    pid = os.fork()
    if pid == 0:
        os._exit(0)
    os.waitpid(pid, 0)
    return pid


class Holder:
    """A child process that takes the study's lock and holds it ``seconds`` (or until killed)."""

    def __init__(self, study, watch_pid: int | None = None, seconds: float = 60.0):
        read, write = os.pipe()
        self.pid = os.fork()
        if self.pid == 0:  # the child: lock, say so, hold, end without cleaning up
            code = 1
            try:
                os.close(read)
                lock = lock_study(study, watch_pid)  # held while this file object is open
                os.write(write, b"locked")
                time.sleep(seconds)
                code = 0 if not lock.closed else 1
            finally:
                os._exit(code)
        os.close(write)
        with os.fdopen(read, "rb") as said:
            assert said.read(6) == b"locked", "the holder could not take the lock"

    def kill(self) -> None:
        os.kill(self.pid, signal.SIGKILL)
        self.wait()

    def wait(self) -> int:
        return os.waitstatus_to_exitcode(os.waitpid(self.pid, 0)[1])


def test_a_second_holder_is_refused_while_the_first_runs(study):
    holder = Holder(study)
    try:
        assert running_daemon(study) == holder.pid
        assert json.loads(study.files.daemon_lock.read_text()) == {
            "pid": holder.pid,
            "watch_pid": None,
        }
        with pytest.raises(DemcalError, match="another demcal daemon is running study"):
            lock_study(study)
    finally:
        holder.kill()


def test_the_lock_is_released_when_its_holder_is_killed(study):
    holder = Holder(study)
    holder.kill()  # SIGKILL: no chance to unlock or remove the file
    assert study.files.daemon_lock.exists()
    assert running_daemon(study) is None
    lock = lock_study(study, watch_pid=123)
    try:
        assert running_daemon(study) == os.getpid()
        assert json.loads(study.files.daemon_lock.read_text()) == {
            "pid": os.getpid(),
            "watch_pid": 123,
        }
    finally:
        lock.close()


def test_two_locks_in_one_process_exclude_each_other_until_closed(study):
    first = lock_study(study)
    with pytest.raises(DemcalError, match=f"study {study.name!r}"):
        lock_study(study)
    first.close()
    assert running_daemon(study) is None
    lock_study(study).close()


def test_a_holder_whose_snakemake_is_alive_is_not_waited_for(study):
    holder = Holder(study, watch_pid=os.getpid())  # holds until killed: a wait would hang
    try:
        with pytest.raises(DemcalError, match="'demcal stop' ends it"):
            lock_study(study)
    finally:
        holder.kill()


def test_a_holder_whose_snakemake_is_gone_is_waited_for(study):
    holder = Holder(study, watch_pid=dead_pid(), seconds=1.0)  # ends by itself after a second
    lock = lock_study(study)  # refused at once, were the holder not waited for
    try:
        assert holder.wait() == 0  # it ended by itself, releasing the lock
        assert running_daemon(study) == os.getpid()
    finally:
        lock.close()
