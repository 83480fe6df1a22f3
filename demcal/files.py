"""File contract between the daemon and the jobs of one evaluation.

Final files are written atomically (temporary name, then ``os.replace``), so a
reader never sees half a file; every file read back is parsed defensively and
a damaged one is reported as such, never as a crash of the reader.
"""

from __future__ import annotations

import csv
import json
import math
import os
import tempfile
from pathlib import Path

from demcal.errors import SimulationFailed

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


def _finite_or_none(value):
    """JSON has no NaN/Infinity: store non-finite floats as null."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite_or_none(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite_or_none(v) for v in value]
    return value


def write_json(path: Path, record: dict) -> None:
    """Atomically write a JSON record (non-finite floats become null)."""
    atomic_write_text(path, json.dumps(_finite_or_none(record), indent=2, sort_keys=True) + "\n")


def read_json(path: Path, what: str) -> dict:
    """Read a JSON object; a missing, truncated or garbled file raises SimulationFailed."""
    path = Path(path)
    try:
        record = json.loads(path.read_text())
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

    def __init__(self, path: Path, clock):
        self.path = Path(path)
        self.clock = clock
        self.start = clock()
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with open(self.path, "w", newline="") as handle:
            csv.writer(handle).writerow(PARTIAL_COLUMNS)

    def write(self, progress: float, stage: str, estimates: dict[str, float] | None = None,
              final: bool = False) -> None:
        rows = [(r, v, int(final)) for r, v in (estimates or {}).items()] or [("", "", "")]
        wall = f"{self.clock() - self.start:.3f}"
        with open(self.path, "a", newline="") as handle:
            writer = csv.writer(handle)
            for response, value, is_final in rows:
                writer.writerow((wall, f"{progress:.4f}", stage, response, value, is_final))


def read_partial(path: Path) -> list[dict]:
    """Rows of a partial.csv as dicts; a torn last line (run still writing) is skipped."""
    rows = []
    try:
        with open(path, newline="") as handle:
            for row in csv.DictReader(handle):
                try:
                    rows.append({
                        "wall_s": float(row["wall_s"]),
                        "progress": float(row["progress"]),
                        "stage": row["stage"],
                        "response": row["response"] or None,
                        "value": float(row["value"]) if row["value"] else None,
                        "final": row.get("final") == "1",
                    })
                except (KeyError, TypeError, ValueError):
                    continue
    except FileNotFoundError:
        return []
    return rows


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
    return " | ".join(line if len(line) <= TAIL_LINE_CHARS else "..." + line[-TAIL_LINE_CHARS:]
                      for line in text[-lines:])
