"""File contract between the daemon and the jobs of one evaluation.

Final files are written atomically (temporary name, then ``os.replace``), so a
reader never sees half a file; every file read back is parsed defensively and
a damaged one is reported as such, never as a crash of the reader.
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import os
import tempfile
from collections.abc import Callable
from itertools import zip_longest
from pathlib import Path
from stat import S_ISREG
from typing import IO, Any

from demcal.errors import SimulationFailed
from demcal.results.layout import PARTIAL_FILE

PARTIAL_COLUMNS = ("wall_s", "progress", "stage", "response", "value", "final")


def _file_mode() -> int:
    """Permissions of a newly created file under the current umask (mkstemp makes 0600)."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


FILE_MODE = _file_mode()


def atomic_write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` so that readers see the old file or the whole new one."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.fchmod(fd, FILE_MODE)
        with os.fdopen(fd, "w") as handle:
            handle.write(text)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _finite_or_none(value: Any) -> Any:
    """JSON has no NaN/Infinity: store non-finite floats as null."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite_or_none(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite_or_none(v) for v in value]
    return value


def json_text(record: dict[str, Any]) -> str:
    """A record as demcal writes JSON: sorted keys, indented, non-finite floats as null."""
    return json.dumps(_finite_or_none(record), indent=2, sort_keys=True) + "\n"


def write_json(path: Path, record: dict[str, Any]) -> None:
    """Atomically write a JSON record (non-finite floats become null)."""
    atomic_write_text(path, json_text(record))


def write_json_if_changed(path: Path, record: dict[str, Any]) -> bool:
    """Write a JSON record unless ``path`` already holds it, so that its modification time
    (Snakemake's rerun trigger) moves only when it changes; True if written."""
    text = json_text(record)
    try:
        if Path(path).read_text() == text:
            return False
    except (OSError, UnicodeDecodeError):
        pass
    atomic_write_text(path, text)
    return True


def file_sha256(path: Path | str) -> str:
    """sha256 of a file's content (what a simulation read: a simulator, its input file)."""
    with open(path, "rb") as stream:
        return hashlib.file_digest(stream, "sha256").hexdigest()


def byte_size(count: int) -> str:
    """A size for a message: in bytes below a megabyte, else in MB."""
    return f"{count} bytes" if count < 2**20 else f"{count / 2**20:.3g} MB"


def read_json(path: Path | str, what: str, limit: int | None = None) -> dict[str, Any]:
    """Read a JSON object; a missing, truncated or garbled file, or one of more than ``limit``
    bytes (read no further), raises SimulationFailed."""
    path = Path(path)
    try:
        with open(path, "rb") as handle:
            text = handle.read(-1 if limit is None else limit + 1)
            if limit is not None and len(text) > limit:
                size = os.fstat(handle.fileno()).st_size
                raise SimulationFailed(
                    f"{what} {path} is {byte_size(size)}, more than the limit of {byte_size(limit)}"
                )
        record = json.loads(text)
    except FileNotFoundError:
        raise SimulationFailed(f"{what} missing: {path}") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise SimulationFailed(f"{what} unreadable ({path}): {exc}") from None
    if not isinstance(record, dict):
        raise SimulationFailed(f"{what} is not a JSON object: {path}")
    return record


class PartialWriter:
    """Appends progress and early response estimates to ``partial.csv`` while a run goes on.

    Each row: wall seconds since start, progress in [0, 1], stage name, and
    optionally a response with its current estimate, flagged ``final`` (1)
    when the value will not change any more (a fill's bulk density once the
    fill has settled) and 0 while it is an early estimate. Lines are flushed
    one by one so the daemon can read them during the run.
    """

    def __init__(self, path: Path, clock: Callable[[], float]):
        self.path = Path(path)
        self.clock = clock
        self.start = clock()
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with open(self.path, "w", newline="") as handle:
            csv.writer(handle).writerow(PARTIAL_COLUMNS)

    def write(
        self,
        progress: float,
        stage: str,
        estimates: dict[str, float] | None = None,
        final: bool = False,
    ) -> None:
        rows: list[tuple[str, float | str, int | str]] = [
            (r, v, int(final)) for r, v in (estimates or {}).items()
        ] or [("", "", "")]
        wall = f"{self.clock() - self.start:.3f}"
        with open(self.path, "a", newline="") as handle:
            writer = csv.writer(handle)
            for response, value, is_final in rows:
                writer.writerow((wall, f"{progress:.4f}", stage, response, value, is_final))


def partial_row(row: dict[str | None, Any]) -> dict[str, Any] | None:
    """One row of a partial.csv (a dict by its header) with its numbers read; None if damaged."""
    try:
        return {
            "wall_s": float(row["wall_s"]),
            "progress": float(row["progress"]),
            "stage": row["stage"],
            "response": row["response"] or None,
            "value": float(row["value"]) if row["value"] else None,
            "final": row.get("final") == "1",
        }
    except (KeyError, TypeError, ValueError):
        return None


def read_partial(path: Path) -> list[dict[str, Any]]:
    """Rows of a partial.csv as dicts; a torn last line (run still writing) is skipped."""
    try:
        with open(path, newline="") as handle:
            return [row for row in map(partial_row, csv.DictReader(handle)) if row is not None]
    except FileNotFoundError:
        return []


#: Bytes a GrowingCsv reads at a time, and of the end of what it read (checked unchanged).
CHUNK_BYTES, MARK_BYTES = 2**20, 256


class GrowingCsv:
    """A CSV file that another process appends to, read on from where the last read stopped.

    ``read_on`` hands each row completed since the last call to ``take`` (a
    dict by the header's names); a last line without its newline waits until
    it is complete. A file truncated, rewritten or replaced is read again from
    its start, after ``forget`` drops what was learnt from the old one. Only
    new bytes are read, a chunk at a time; a file of more than ``limit`` bytes
    raises SimulationFailed. Subclasses say what a row means.
    """

    def __init__(self, path: Path, what: str, limit: int | None = None):
        self.path, self.what, self.limit = Path(path), what, limit
        self._start(None)

    def forget(self) -> None:
        """Drop what was learnt from the rows read so far."""

    def take(self, row: dict[str | None, str | None]) -> None:
        """Learn from one row."""

    def _start(self, identity: tuple[int, int] | None) -> None:
        self.identity, self.offset, self.mark = identity, 0, b""
        self.columns: list[str] | None = None
        self.forget()

    def read_on(self) -> None:
        """Read the rows completed since the last call (none while the file is missing)."""
        try:  # without blocking: a FIFO in the file's place would wait for a writer
            with open(os.open(self.path, os.O_RDONLY | os.O_NONBLOCK), "rb") as handle:
                self._read_on(handle)
        except OSError:
            return  # not written yet, or unreadable: nothing new

    def _read_on(self, handle: IO[bytes]) -> None:
        stat = os.fstat(handle.fileno())
        if not S_ISREG(stat.st_mode):
            return
        if self.limit is not None and stat.st_size > self.limit:
            raise SimulationFailed(f"{self.what} grew beyond {byte_size(self.limit)}")
        identity = (stat.st_dev, stat.st_ino)
        before = os.pread(handle.fileno(), len(self.mark), self.offset - len(self.mark))
        if identity != self.identity or stat.st_size < self.offset or before != self.mark:
            self._start(identity)
        handle.seek(self.offset)
        remaining, pending = stat.st_size - self.offset, b""
        while remaining > 0 and (chunk := handle.read(min(CHUNK_BYTES, remaining))):
            remaining -= len(chunk)
            pending += chunk
            end = pending.rfind(b"\n") + 1
            if end:
                self._take_lines(pending[:end])
                pending = pending[end:]

    def _take_lines(self, lines: bytes) -> None:
        self.offset += len(lines)
        self.mark = (self.mark + lines[-MARK_BYTES:])[-MARK_BYTES:]
        for line in lines.decode(errors="replace").split("\n"):
            try:
                fields = next(csv.reader([line]), [])
            except csv.Error:
                continue
            if not fields:
                continue
            if self.columns is None:
                self.columns = fields
            else:
                self.take(dict(zip_longest(self.columns, fields)))


#: Longest log line quoted in a reason (its end: where errors are); bytes read from a log's end.
TAIL_LINE_CHARS, TAIL_BYTES = 240, 64 * 1024


def log_tail(path: Path, lines: int = 5) -> str:
    """The last ``lines`` lines of a log joined with " | " (empty if unreadable), for reasons.

    Reads only the log's end, and quotes at most the last TAIL_LINE_CHARS
    characters of each line (a simulator may write megabytes on one line).
    """
    try:
        with open(path, "rb") as handle:
            handle.seek(max(handle.seek(0, 2) - TAIL_BYTES, 0))
            text = handle.read().decode(errors="replace").strip().splitlines()
    except OSError:
        return ""
    return " | ".join(
        line if len(line) <= TAIL_LINE_CHARS else "..." + line[-TAIL_LINE_CHARS:]
        for line in text[-lines:]
    )


class LatestReports(GrowingCsv):
    """(value, final) of the latest report of each response in a simulation's partial.csv,
    and its latest progress (0-1)."""

    def __init__(self, path: Path):
        super().__init__(path, PARTIAL_FILE)

    def forget(self) -> None:
        self.latest: dict[str, tuple[float, bool]] = {}
        self.progress = 0.0

    def take(self, row: dict[str | None, str | None]) -> None:
        report = partial_row(row)
        if report is None:
            return
        self.progress = min(max(report["progress"], 0.0), 1.0)
        if report["response"] is not None and report["value"] is not None:
            self.latest[report["response"]] = (report["value"], report["final"])
