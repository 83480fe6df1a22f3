"""Several processes writing into one archive: none lost, none stored twice; a writer killed
with SIGKILL inside its transaction leaves nothing of it behind."""

from __future__ import annotations

import multiprocessing
import os
import signal
import time
from collections import Counter

import pytest
from archive_helpers import DATABASES, new_archive, record
from sqlalchemy import func, select

from demcal.archive.schema import ParameterRow, ResponseRow, SimulationRow
from demcal.archive.store import Archive
from demcal.results.archive_url import open_engine

WRITERS, OWN, SHARED = 4, 25, 10


@pytest.fixture(params=DATABASES)
def archive_url(request, tmp_path) -> str:
    return new_archive(request.param, tmp_path)


def write(url: str, writer: int) -> int:
    """One writer: a transaction per record (as the jobs write), the shared records among its
    own; how many it added."""
    numbers = [*range(SHARED), *range(1000 * (writer + 1), 1000 * (writer + 1) + OWN)]
    added = 0
    with Archive(url) as archive:
        for n in numbers[writer:] + numbers[:writer]:  # each starts somewhere else
            added += archive.add([record(n)])
    return added


def test_concurrent_writers_lose_nothing_and_store_nothing_twice(archive_url):
    context = multiprocessing.get_context("fork")
    with context.Pool(WRITERS) as pool:  # the archive is new: they migrate it at once, too
        added = pool.starmap(write, [(archive_url, w) for w in range(WRITERS)])
    assert sum(added) == SHARED + WRITERS * OWN
    with Archive(archive_url) as archive:
        stored = archive.records()
    assert len(stored) == SHARED + WRITERS * OWN
    assert max(Counter(r.key for r in stored).values()) == 1
    assert all(len(r.parameters) == 3 and len(r.responses) == 2 for r in stored)


def slow_records(ready: str):
    """Records that stop coming after the second: the writer waits inside its transaction."""
    yield record(0)
    yield record(1)
    open(ready, "w").close()
    time.sleep(600)
    yield record(2)


def test_a_writer_killed_in_its_transaction_leaves_no_partial_record(archive_url, tmp_path):
    ready = tmp_path / "inside"
    with Archive(archive_url) as archive:
        archive.add([record(9)])
    pid = os.fork()
    if pid == 0:  # the writer
        try:
            Archive(archive_url).add(slow_records(str(ready)))
        finally:
            os._exit(1)
    deadline = time.monotonic() + 30
    while not ready.exists() and time.monotonic() < deadline:
        time.sleep(0.01)
    assert ready.exists(), "the writer never got inside its transaction"
    os.kill(pid, signal.SIGKILL)
    os.waitpid(pid, 0)
    with Archive(archive_url) as archive:
        assert [r.evaluation for r in archive.records()] == ["e0009"]
        assert archive.add([record(0)]) == 1  # its lock is gone with it
    engine = open_engine(archive_url)
    with engine.connect() as connection:
        counts = [
            connection.execute(select(func.count()).select_from(table)).scalar_one()
            for table in (SimulationRow, ParameterRow, ResponseRow)
        ]
    engine.dispose()
    assert counts == [2, 6, 4]
