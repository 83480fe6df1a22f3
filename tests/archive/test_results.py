"""The archive fed by the jobs and by ``demcal archive import``, its place in the study file,
and its commands (on SQLite; tests/archive/test_store.py covers PostgreSQL)."""

from __future__ import annotations

import logging
import re

import pandas as pd
import pytest
from archive_helpers import record
from helpers import analytic_example, run_in_process

from demcal.archive import export
from demcal.archive.importer import import_results
from demcal.archive.simulation import from_results
from demcal.archive.store import Archive
from demcal.cli import main
from demcal.errors import ConfigError
from demcal.jobs.steps import archive, extract, simulate
from demcal.results.archive_url import check_url
from demcal.results.layout import StudyFiles
from demcal.results.records import PointRecord, ResponsesRecord, SimulationRecord, Status
from demcal.results.storage import PartialWriter
from demcal.study.config import load_study
from demcal.study.model import freeze

DEFAULT = "sqlite:///results/archive.sqlite"


@pytest.fixture
def study(tmp_path, monkeypatch):
    """The analytic example frozen in a fresh project folder (its archive: the default)."""
    monkeypatch.chdir(tmp_path)
    return freeze(load_study(analytic_example(replicates=2)))


def test_every_simulation_of_a_calibration_is_archived_once(study):
    run_in_process(study, evaluations=3)
    with Archive(DEFAULT) as archive:
        stored = archive.records()
        assert len(stored) == 3 * 2
        assert {(r.evaluation, r.replicate) for r in stored} == {
            (f"e000{e}", r) for e in range(3) for r in range(2)
        }
        first = stored[0]
        assert first.study == study.name and first.engine == "analytic"
        assert first.free == {"sliding_friction_pp", "rolling_friction_pp"}
        assert first.parameters["particle_density"].unit == "kg/m^3"
        assert first.psd["d50"].unit == "m"
        assert first.responses["angle_of_repose"].unit == "deg"
        assert first.cost["cpu_s"] >= 0.0
        # the jobs' records are what an import of the folder finds: nothing new, twice
        for _ in range(2):
            report = import_results(archive, study.files.dir)
            assert (report.found, report.added, report.skipped) == (6, 0, [])


def test_import_twice_adds_nothing(study, tmp_path):
    run_in_process(study, evaluations=2)
    url = f"sqlite:///{tmp_path / 'other.sqlite'}"
    with Archive(url) as archive:
        assert import_results(archive, study.files.dir).added == 4
        assert import_results(archive, study.files.dir).added == 0
        assert {r.source for r in archive.records()} == {"import"}


def test_an_unfinished_replicate_is_skipped_and_named(study):
    run_in_process(study, evaluations=1)
    study.files.evaluation("e0000").replicate("cylinder_lift", 1).responses.unlink()
    with Archive("sqlite:///elsewhere.sqlite") as archive:
        report = import_results(archive, study.files.dir)
    assert (report.found, report.added) == (1, 1)
    assert report.skipped == [
        f"{study.files.dir}/evals/e0000/cylinder_lift/rep1: no responses.json yet"
    ]


def test_a_stopped_run_keeps_its_last_estimates(study, tmp_path):
    partial = tmp_path / "partial.csv"
    writer = PartialWriter(partial, lambda: 1.0)
    writer.write(0.3, "run", {"angle_of_repose": 31.0}, False)
    writer.write(0.6, "run", {"angle_of_repose": 27.0, "bulk_density": 1400.0}, True)
    simulation = SimulationRecord(
        "e0000", "cylinder_lift", 0, "analytic", "analytic-1", {}, 0.25, [], 0.0, Status.TERMINATED
    )
    stopped = ResponsesRecord(Status.TERMINATED, "stopped early (STOP requested)")
    found = from_results(study, simulation, stopped, partial)
    assert {n: q.value for n, q in found.responses.items()} == {
        "angle_of_repose": 27.0,
        "bulk_density": 1400.0,
    }
    assert found.final == {"angle_of_repose": True, "bulk_density": True}
    failed = from_results(study, simulation, ResponsesRecord(Status.FAILED, "x"), partial)
    assert failed.responses == {}


def test_a_failed_archive_write_leaves_the_evaluation_whole(tmp_path, monkeypatch, caplog):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "taken").mkdir()  # a folder where the archive's file would be
    study = freeze(load_study(analytic_example(archive={"url": "sqlite:///taken"})))
    files = study.files.evaluation("e0000")
    PointRecord(study.centre_point()).write(files.params)
    simulate(study, "e0000", "cylinder_lift", 0)
    record_ = extract(study, files.replicate("cylinder_lift", 0).simulation)
    with caplog.at_level(logging.WARNING, logger="demcal"):
        assert archive(study, "e0000") == 0
    assert record_.status == Status.OK
    assert ResponsesRecord.read(files.replicate("cylinder_lift", 0).responses) == record_
    assert files.archived.exists()  # the job is done: the warning says how to record them
    assert "not archived" in caplog.text and "demcal archive import --url " in caplog.text


def test_archive_false_records_nothing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    study = freeze(load_study(analytic_example(archive=False)))
    assert study.archive is None
    run_in_process(study, evaluations=1)
    assert not (tmp_path / "results" / "archive.sqlite").exists()


@pytest.mark.parametrize(
    "archive, message",
    [
        ({"url": "mysql://host/db"}, "archive.url: mysql:// is not a database demcal can"),
        ({"url": "http://host/db"}, "archive.url: http:// is not a database demcal can"),
        ({"url": "file:///tmp/a.sqlite"}, "archive.url: file:// is not a database demcal"),
        ({"url": "not a url"}, "archive.url: 'not a url' is not a database URL"),
        ({"url": "sqlite://"}, "archive.url: 'sqlite://' names no file"),
        ({"url": "postgresql://host"}, "archive.url: 'postgresql://host' names no database"),
        ({"url": "postgresql+asyncpg://h/d"}, "archive.url: driver 'asyncpg' is not installed"),
        ({"url": "sqlite+aiosqlite:///a.sqlite"}, "archive.url: driver 'aiosqlite' is not"),
        ({"url": "postgresql://h:abc/d"}, "archive.url: 'postgresql://h:abc/d' is not a database"),
        ({"url": 5}, "archive.url: 5 is not of type string"),
        ({"path": "a.sqlite"}, "archive.path: unknown field; allowed here: url"),
        ({}, "archive: missing required field 'url'"),
        ("yes", "archive: 'yes' is not of type ['object', 'boolean']"),
    ],
)
def test_a_bad_archive_setting_names_the_field(archive, message):
    with pytest.raises(ConfigError) as error:
        load_study(analytic_example(archive=archive), check_engine=False)
    assert message in str(error.value)


def test_the_archive_may_change_on_resume(study):
    url = "sqlite:///team.sqlite"
    moved = freeze(load_study(analytic_example(replicates=2, archive={"url": url})))
    assert (study.archive, moved.archive) == (DEFAULT, url)


def test_export_round_trip(tmp_path):
    written = [
        record(0),
        record(1, status=Status.TERMINATED, final={"angle_of_repose": False, "bulk_density": True}),
        record(2, status=Status.FAILED, reason="engine error", responses={}, final={}),
    ]
    with Archive(f"sqlite:///{tmp_path / 'a.sqlite'}") as archive:
        archive.add(written)
        table = export.frame(archive.records())
    assert "parameter.particle_density [kg/m^3]" in table.columns
    assert "response.angle_of_repose [deg]" in table.columns
    assert "psd.d50 [m]" in table.columns and "cost.cpu [s]" in table.columns
    assert list(table["response.angle_of_repose.final"].iloc[:2]) == [True, False]
    for suffix in export.FORMATS:
        path = tmp_path / f"export{suffix}"
        export.write_table(table, path)
        back = export.read(path)
        assert list(back.columns) == list(table.columns)
        pd.testing.assert_frame_equal(back, table, check_dtype=False)
    assert list(table.columns[: len(export.FIXED_COLUMNS)]) == list(export.FIXED_COLUMNS)
    empty = export.frame([])
    export.write_table(empty, tmp_path / "empty.csv")
    assert (tmp_path / "empty.csv").read_text().startswith("id,key,study,evaluation,")


def test_reading_an_archive_that_is_not_there_names_it_and_makes_no_file(tmp_path, capsys):
    url = f"sqlite:///{tmp_path / 'none' / 'archive.sqlite'}"
    for action in (["list"], ["show", "1"], ["stats"], ["export", str(tmp_path / "x.csv")]):
        assert main(["archive", *action, "--url", url]) == 2
        assert "no archive at" in capsys.readouterr().err
    assert not (tmp_path / "none").exists()


def test_the_commands(study, tmp_path, capsys):
    run_in_process(study, evaluations=1)
    assert main(["archive", "import"]) == 0
    assert "study analytic-demo: 2 simulations found, 0 new" in capsys.readouterr().out
    assert main(["archive", "list", "--status", "ok"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 2 and "analytic-demo/e0000 cylinder_lift rep0 ok 20" in lines[0]
    assert re.search(r" ok \d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ \w+_friction_pp=\S+ ", lines[0])
    assert " | angle_of_repose=" in lines[0]
    assert main(["archive", "show", lines[0].split()[0]]) == 0
    shown = capsys.readouterr().out
    assert '"angle_of_repose": "' in shown and re.search(r'"started_at": "\d{4}-.*Z"', shown)
    # --study keeps one study's simulations; --archive-of chooses the archive
    assert main(["archive", "list", "--study", "my-beads"]) == 0
    assert "no simulations in sqlite:///results/archive.sqlite match" in capsys.readouterr().out
    assert main(["archive", "list", "--archive-of", "analytic-demo", "--of", "analytic-demo"]) == 0
    assert len(capsys.readouterr().out.splitlines()) == 2
    assert main(["archive", "stats", "--study", "analytic-demo"]) == 0
    assert "analytic-demo cylinder_lift analytic ok: 2" in capsys.readouterr().out
    assert main(["archive", "export", str(tmp_path / "all.parquet")]) == 0
    assert len(pd.read_parquet(tmp_path / "all.parquet")) == 2
    assert main(["archive", "show", "zzzzzzzz"]) == 2
    assert "holds no simulation 'zzzzzzzz'" in capsys.readouterr().err
    assert main(["archive", "export", str(tmp_path / "all.xlsx")]) == 2
    assert "give a file ending in .csv or .parquet" in capsys.readouterr().err
    assert main(["archive", "list", "--url", "oracle://x/y"]) == 2
    assert "--url: oracle:// is not a database demcal can" in capsys.readouterr().err


def test_a_folder_without_a_study_is_named(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["archive", "import", str(tmp_path)]) == 2
    assert "no study.json here" in capsys.readouterr().out
    assert StudyFiles.of("none").dir.name == "none"


def test_postgres_is_read_as_postgresql():
    """``postgres://``, the spelling SQLAlchemy dropped, names a PostgreSQL database."""
    assert check_url("postgres://user:secret@host:5432/db") == (
        "postgresql://user:secret@host:5432/db"
    )
    assert check_url("postgres+psycopg://host/db") == "postgresql+psycopg://host/db"
