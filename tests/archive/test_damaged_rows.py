"""Damaged rows of an archive (issue 35, item 4): what cannot be used is left out and named in
one warning, never raised. PostgreSQL holds NaN and infinity; a hand-edited SQLite file may
hold text in a number column, a JSON column that is not JSON, an unknown status."""

from __future__ import annotations

import json
from dataclasses import replace

import pytest
from archive_helpers import DATABASES, new_archive, record, stored
from helpers import analytic_example, run_in_process
from sqlalchemy import text

from demcal.archive.importer import import_results
from demcal.archive.store import Archive
from demcal.results.archive_url import open_engine
from demcal.results.records import Status
from demcal.study.config import load_study
from demcal.study.model import freeze


@pytest.fixture(params=DATABASES)
def archive_url(request, tmp_path) -> str:
    return new_archive(request.param, tmp_path)


def change(url: str, update: str, **values: object) -> None:
    """Run ``update`` on the archive behind demcal's back (SQLite's CHECK constraints off)."""
    engine = open_engine(url)
    with engine.begin() as connection:
        if engine.dialect.name == "sqlite":
            connection.execute(text("PRAGMA ignore_check_constraints = 1"))
        connection.execute(text(update), values)
    engine.dispose()


def stored_records(url: str, count: int = 4) -> None:
    """Store the records 0 to ``count - 1`` (ids 1 to ``count``)."""
    with Archive(url) as archive:
        archive.add([record(n) for n in range(count)])


RESPONSE = "UPDATE responses SET value = :value WHERE simulation_id = :id AND name = :name"


def test_a_response_or_parameter_that_is_not_a_finite_number_is_named(archive_url, capsys):
    """A bad response leaves the rest of its simulation sound; a bad parameter does not (the
    point it ran at is unknown)."""
    stored_records(archive_url)
    bad = "abc" if archive_url.startswith("sqlite") else float("nan")
    change(archive_url, RESPONSE, value=bad, id=1, name="angle_of_repose")
    change(archive_url, RESPONSE, value=float("inf"), id=2, name="bulk_density")
    change(
        archive_url,
        "UPDATE parameters SET value = :value WHERE simulation_id = 3 AND name = 'restitution_pp'",
        value=float("-inf"),
    )
    with Archive(archive_url) as archive:
        found = archive.records()
        assert [r.id for r in found] == [1, 2, 4]
        assert found[0].responses == {"bulk_density": record(0).responses["bulk_density"]}
        assert found[0].final == {"bulk_density": True}
        assert set(found[1].responses) == set(found[1].final) == {"angle_of_repose"}
        assert stored(found[2]) == record(3)
        summary = archive.damage_summary()
        assert summary == (
            f"archive {archive_url}: skipped 1 damaged simulation (id 3: parameter "
            f"restitution_pp is -inf, not a finite number), and left damaged values out of 2 "
            f"damaged simulations (id 1: response angle_of_repose is {bad!r}, not a finite "
            f"number; id 2: response bulk_density is inf, not a finite number)"
        )
        archive.warn_damaged()
        archive.warn_damaged()  # said once
        assert capsys.readouterr().err.splitlines() == [f"demcal: warning: {summary}"]
        assert archive.damage_summary() is None
        assert [(r["status"], r["simulations"], r["cpu_s"]) for r in archive.stats()] == [
            ("ok", 3, 4.5)
        ]
        assert archive.get("1") == found[0]
        assert archive.get("3") is None
        assert "id 3: parameter restitution_pp is -inf" in (archive.damage_summary() or "")


def test_text_bad_json_and_an_unknown_status_are_named(tmp_path):
    """What only a hand-edited SQLite file holds: each flaw named with its simulation."""
    url = new_archive("sqlite", tmp_path)
    stored_records(url, 8)
    change(url, RESPONSE, value="", id=1, name="bulk_density")
    change(url, "UPDATE simulations SET psd = 'not json' WHERE id = 2")
    change(url, """UPDATE simulations SET psd = '{"d50": 0.002}' WHERE id = 3""")
    change(url, "UPDATE simulations SET status = 'weird' WHERE id = 4")
    change(url, "UPDATE simulations SET settings = '[1, 2]' WHERE id = 5")
    change(url, "UPDATE simulations SET cost = '{' WHERE id = 6")
    change(url, "UPDATE simulations SET seed = 'x', replicate = 'y' WHERE id = 7")
    with Archive(url) as archive:
        found = {r.id: r for r in archive.records()}
        assert sorted(found) == [1, 2, 3, 8]
        assert found[2].psd == found[3].psd == {}
        assert stored(found[1]) == replace(
            record(0),
            responses={"angle_of_repose": record(0).responses["angle_of_repose"]},
            final={"angle_of_repose": True},
        )
        assert archive.damage_summary() == (
            f"archive {url}: skipped 4 damaged simulations (id 4: status 'weird' is not one of "
            f"ok, failed, terminated; id 5: settings is not a JSON object; id 6: cost is not a "
            f"JSON object; id 7: replicate is 'y', not a finite number and seed is 'x', not a "
            f"finite number), and left damaged values out of 3 damaged simulations (id 1: "
            f"response bulk_density is '', not a finite number; id 2: psd is not a JSON object; "
            f"id 3: psd d50 has no unit)"
        )
        assert [r.evaluation for r in archive.records(statuses=[Status.FAILED])] == []


def test_the_warning_names_at_most_ten_ids_of_one_flaw(tmp_path):
    url = new_archive("sqlite", tmp_path)
    stored_records(url, 12)
    change(url, "UPDATE responses SET value = 9e999 WHERE name = 'angle_of_repose'")
    with Archive(url) as archive:
        assert len(archive.records()) == 12
        assert archive.damage_summary() == (
            f"archive {url}: left damaged values out of 12 damaged simulations (ids 1, 2, 3, "
            f"4, 5, 6, 7, 8, 9, 10, and 2 more: response angle_of_repose is inf, not a finite "
            f"number)"
        )


def test_an_import_skips_the_replicate_with_a_nan_response(tmp_path, monkeypatch):
    """SQLite cannot keep NaN: the replicate is named, the others are imported."""
    monkeypatch.chdir(tmp_path)
    study = freeze(load_study(analytic_example(replicates=2)))
    run_in_process(study, evaluations=2)
    responses = study.files.evaluation("e0001").replicate("cylinder_lift", 0).responses
    written = json.loads(responses.read_text())
    written["responses"]["bulk_density"] = float("nan")
    responses.write_text(json.dumps(written))
    with Archive(f"sqlite:///{tmp_path / 'other.sqlite'}") as archive:
        report = import_results(archive, study.files.dir)
        assert (report.found, report.added) == (3, 3)
        assert report.skipped == [
            f"{responses.parent}: response bulk_density is nan, not a finite number"
        ]
        assert ("e0001", 0) not in {(r.evaluation, r.replicate) for r in archive.records()}
