"""Bad-command cases: damaged rows of an archive (issue 35, item 4).

The finished small study's archive (results/archive.sqlite, five ok simulations, ids 1 to 5)
is changed behind demcal's back, as a hand edit of the SQLite file or a PostgreSQL archive
holding NaN and infinity could leave it: a response that is text or infinite, a psd that is
not JSON, a status the archive does not know. Every command that reads the archive must skip
what it cannot use, name it in one warning line, and carry on; ``archive import`` of a folder
with one NaN response imports the other replicates.
"""

from __future__ import annotations

import contextlib
import json
import sqlite3
from collections.abc import Callable
from pathlib import Path

from bad_commands import SMALL_STUDY, BadCommand, finished_study, write_study

#: A response that is text (SQLite keeps it in a REAL column).
TEXT = "UPDATE responses SET value = 'abc' WHERE simulation_id = 2 AND name = 'angle_of_repose'"
#: A response that is infinite (9e999 overflows to inf).
INFINITE = "UPDATE responses SET value = 9e999 WHERE simulation_id = 3 AND name = 'bulk_density'"
#: A particle-size distribution that is not JSON.
PSD = "UPDATE simulations SET psd = 'not json' WHERE id = 4"
#: A status the archive does not know (its CHECK constraint set aside).
STATUS = "UPDATE simulations SET status = 'weird' WHERE id = 1"

#: How the warning names each damage.
TEXT_SAID = r"id 2: response angle_of_repose is 'abc', not a finite number"
INFINITE_SAID = r"id 3: response bulk_density is inf, not a finite number"
PSD_SAID = r"id 4: psd is not a JSON object"
STATUS_SAID = r"id 1: status 'weird' is not one of ok, failed, terminated"
WARNING = r"demcal: warning: archive sqlite:///\S+archive.sqlite: "
#: The warning for all four damages at once.
ALL_SAID = (
    rf"{WARNING}skipped 1 damaged simulation \({STATUS_SAID}\), and left damaged values out "
    rf"of 3 damaged simulations \({TEXT_SAID}; {INFINITE_SAID}; {PSD_SAID}\)"
)


def damaged(*updates: str) -> Callable[[Path], None]:
    """Prepare the finished small study with its archive changed by the SQL ``updates``."""

    def prepare(folder: Path) -> None:
        finished_study(folder)
        with contextlib.closing(sqlite3.connect(folder / "results" / "archive.sqlite")) as db:
            db.execute("PRAGMA ignore_check_constraints = 1")
            for update in updates:
                db.execute(update)
            db.commit()

    return prepare


def listed(*ids: int) -> str:
    """The lines of ``archive list`` for these ids, in order (other lines between)."""
    return "(?m)" + "".join(rf"^\s+{i} small/e\d{{4}} .*\n(?:.*\n)*?" for i in ids)


def nan_in_one_replicate(folder: Path) -> None:
    """The finished small study without its archive; one replicate's angle of repose NaN."""
    finished_study(folder)
    (folder / "results" / "archive.sqlite").unlink()
    responses = folder / "results" / "small" / "evals" / "e0002" / "cylinder_lift" / "rep0"
    record = json.loads((responses / "responses.json").read_text())
    record["responses"]["angle_of_repose"] = float("nan")
    (responses / "responses.json").write_text(json.dumps(record))  # NaN, as Python spells it


def reusing_study(*updates: str) -> Callable[[Path], None]:
    """The damaged archive and a second study of the same material that reuses it."""

    def prepare(folder: Path) -> None:
        damaged(*updates)(folder)
        config = {
            **SMALL_STUDY,
            "study": "again",
            "reuse": "archive",
            "optimizer": {**SMALL_STUDY["optimizer"], "max_evaluations": 1},
        }
        write_study(folder, config, "again.yaml")

    return prepare


CASES: list[BadCommand] = [
    *(
        BadCommand(
            f"archive_list_{name}",
            ("archive", "list"),
            listed(*ids) + rf"{WARNING}{done} 1 damaged simulation \({said}\)",
            damaged(update),
            "warned",
        )
        for name, update, said, done, ids in (
            ("text_response", TEXT, TEXT_SAID, "left damaged values out of", (1, 2, 3, 4, 5)),
            ("inf_response", INFINITE, INFINITE_SAID, "left damaged values out of", (1, 3, 5)),
            ("psd_not_json", PSD, PSD_SAID, "left damaged values out of", (1, 4, 5)),
            ("unknown_status", STATUS, STATUS_SAID, "skipped", (2, 3, 4, 5)),
        )
    ),
    BadCommand(
        "archive_list_four_damaged_rows",
        ("archive", "list"),
        listed(2, 3, 4, 5) + ALL_SAID,
        damaged(TEXT, INFINITE, PSD, STATUS),
        "warned",
    ),
    *(
        BadCommand(
            f"archive_show_{name}",
            ("archive", "show", str(id_)),
            rf'(?s)"id": {id_},.*{shown}.*{WARNING}left damaged values out of 1 damaged '
            rf"simulation \({said}\)",
            damaged(update),
            "warned",
        )
        for name, update, said, id_, shown in (
            ("text_response", TEXT, TEXT_SAID, 2, r'"bulk_density": "\S+ kg/m\^3"'),
            ("inf_response", INFINITE, INFINITE_SAID, 3, r'"angle_of_repose": "\S+ deg"'),
            ("psd_not_json", PSD, PSD_SAID, 4, r'"psd": \{\}'),
        )
    ),
    BadCommand(  # nothing to show: the refusal says why
        "archive_show_unknown_status",
        ("archive", "show", "1"),
        rf"^demcal: archive sqlite:///\S+: skipped 1 damaged simulation \({STATUS_SAID}\)$",
        damaged(STATUS),
    ),
    *(
        BadCommand(
            f"archive_export_{suffix}_four_damaged_rows",
            ("archive", "export", f"all.{suffix}"),
            rf"(?s)demcal: 4 simulations from \S+ written to all\.{suffix}\n{ALL_SAID}",
            damaged(TEXT, INFINITE, PSD, STATUS),
            "warned",
        )
        for suffix in ("csv", "parquet")
    ),
    BadCommand(
        "archive_stats_four_damaged_rows",
        ("archive", "stats"),
        rf"(?s)sqlite:///\S+: 4 simulations\n\s+small cylinder_lift analytic ok: 4 .*{ALL_SAID}",
        damaged(TEXT, INFINITE, PSD, STATUS),
        "warned",
    ),
    BadCommand(
        "archive_import_nan_response_in_one_replicate",
        ("archive", "import", "results/small"),
        r"results/small: study small: 4 simulations found, 4 new in \S+\n\s+skipped "
        r"\S+/e0002/cylinder_lift/rep0: response angle_of_repose is nan, not a finite number",
        nan_in_one_replicate,
        "warned",
    ),
    # a simulation with a damaged response still counts with its other one: a partial point
    BadCommand(
        "run_reuse_from_archive_with_text_response",
        ("run", "again.yaml"),
        rf"(?s)calibration of 'again' finished.*4 points reused from the archive.*{WARNING}"
        rf"left damaged values out of 1 damaged simulation \({TEXT_SAID}\)",
        reusing_study(TEXT, STATUS),
        "warned",
        timeout=300.0,
    ),
    BadCommand(
        "run_reuse_from_archive_with_inf_response",
        ("run", "again.yaml"),
        rf"(?s)calibration of 'again' finished.*5 points reused from the archive.*{WARNING}"
        rf"left damaged values out of 1 damaged simulation \({INFINITE_SAID}\)",
        reusing_study(INFINITE),
        "warned",
        timeout=300.0,
    ),
    *(
        BadCommand(
            f"metamodel_build_on_archive_with_{name}",
            ("metamodel", "build", "study.yaml", "--model", "kriging"),
            rf"(?s)cylinder_lift\.{response}: trained on 4 simulations.*{WARNING}left damaged "
            rf"values out of 1 damaged simulation \({said}\)",
            damaged(update),
            "warned",
            timeout=300.0,
        )
        for name, update, said, response in (
            ("text_response", TEXT, TEXT_SAID, "angle_of_repose"),
            ("inf_response", INFINITE, INFINITE_SAID, "bulk_density"),
        )
    ),
]
