"""The archive's store: idempotent writes, records read back as written, the search of
compatible simulations, and its schema (migrations), on SQLite and PostgreSQL."""

from __future__ import annotations

from dataclasses import replace

import pytest
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from archive_helpers import DATABASES, SETTINGS, SIMULATOR, new_archive, record, stored
from sqlalchemy import insert, text

from demcal.archive.schema import Base, ParameterRow, SimulationRow
from demcal.archive.simulation import ArchivedSimulation, Quantity
from demcal.archive.store import VERSION_TABLE, Archive, ArchiveError
from demcal.results.archive_url import open_engine
from demcal.results.records import Status


@pytest.fixture(params=DATABASES)
def archive_url(request, tmp_path) -> str:
    return new_archive(request.param, tmp_path)


def test_a_record_is_stored_once(archive_url):
    with Archive(archive_url) as archive:
        assert archive.add([record(0)]) == 1
        assert archive.add([record(0)]) == 0  # a retried job
        assert archive.add([record(0), record(1), record(1)]) == 1
        assert archive.count() == 2
    with Archive(archive_url) as archive:  # a resumed daemon opens it again
        assert archive.add([record(1)]) == 0
        assert archive.count() == 2


def test_a_rerun_with_another_seed_is_another_simulation(archive_url):
    with Archive(archive_url) as archive:
        assert archive.add([record(0), record(0, seed=7, attempt=1)]) == 2


def test_records_read_back_as_written(archive_url):
    written = [
        record(0),
        record(1, status=Status.FAILED, reason="engine error", responses={}, final={}),
        record(
            2,
            status=Status.TERMINATED,
            reason="stopped early (STOP requested)",
            responses={"angle_of_repose": record().responses["angle_of_repose"]},
            final={"angle_of_repose": False},
            seed=None,
        ),
    ]
    with Archive(archive_url) as archive:
        archive.add(written)
        found = archive.records()
        assert [stored(r) for r in found] == written
        assert [r.key for r in found] == [r.key for r in written]
        assert archive.get(found[2].key[:8]) == found[2]
        assert archive.get(str(found[1].id)) == found[1]
        assert archive.get("abc") is None
        assert [r.evaluation for r in archive.records(statuses=["failed"])] == ["e0001"]
        assert len(archive.records(limit=2)) == 2


def test_compatible_records_share_scene_engine_settings_and_fixed_values(archive_url):
    other_density = {
        **record(3).parameters,
        "particle_density": record().parameters["restitution_pp"],
    }
    with Archive(archive_url) as archive:
        archive.add(
            [
                record(0),
                record(1),
                record(2, settings={**SETTINGS, "particle_count": 400}),
                record(3, parameters=other_density),
                record(4, engine="lammps"),
                record(5, scene="shear_box"),
                record(6, status=Status.FAILED, responses={}, final={}),
                record(
                    7, parameters={"sliding_friction_pp": record().parameters["restitution_pp"]}
                ),
                record(8, simulator="b" * 64),  # another simulator
                record(9, simulator=""),  # a simulator that was not recorded
            ]
        )
        fixed = {"restitution_pp": 0.5, "particle_density": 2500.0}

        def found(**given) -> list[str]:
            arguments = {
                "scene": "cylinder_lift",
                "engine": "analytic",
                "settings": dict(SETTINGS),
                "fixed": fixed,
                "inputs": ["sliding_friction_pp"],
                "simulator": SIMULATOR,
            }
            return [r.evaluation for r in archive.compatible(**(arguments | given))]

        assert found() == ["e0000", "e0001"]
        # a fixed parameter that varies is compatible once it is a model input
        assert found(inputs=["sliding_friction_pp", "particle_density"]) == [
            "e0000",
            "e0001",
            "e0003",
        ]
        assert found(fixed={"restitution_pp": 0.6, "particle_density": 2500.0}) == []
        assert found(simulator="b" * 64) == ["e0008"]
        assert found(simulator="") == []  # an unknown simulator is nobody's
        assert found(statuses=["ok", "failed"]) == ["e0000", "e0001", "e0006"]
        assert found(fixed={}, inputs=["sliding_friction_pp"]) == ["e0007"]


def test_the_migrations_build_the_schema_of_the_models(archive_url):
    Archive(archive_url).close()
    engine = open_engine(archive_url)
    with engine.connect() as connection:
        context = MigrationContext.configure(connection, opts={"version_table": VERSION_TABLE})
        assert compare_metadata(context, Base.metadata) == []
    engine.dispose()


def test_the_second_schema_reads_the_first_schemas_records_in_todays_names(archive_url):
    """Migration 0002: one restitution becomes two, the rolling damping ratio of earlier
    versions (0.3) is recorded, d50 and sigma_ln become parameters; 0005: cohesionless
    surface energies; the key is the one the same simulation gets today, so a second import
    of its folder adds nothing."""
    from demcal.archive.store import _row, upgrade

    earlier_parameters = {
        "sliding_friction_pp": record(3).parameters["sliding_friction_pp"],
        "restitution": Quantity(0.7, "-"),
        "particle_density": record(3).parameters["particle_density"],
    }
    earlier = replace(record(3), parameters=earlier_parameters, simulator="")
    bad_parameters = replace(
        record(4),
        status=Status.FAILED,
        parameters={},
        responses={},
        final={},
        free=frozenset(),
        simulator="",
    )
    engine = open_engine(archive_url)
    upgrade(engine, "0001")

    def row_0001(simulation: ArchivedSimulation) -> dict:  # without 0003's and 0004's columns
        later = ("simulator", "fidelity", "fine_level")
        return {k: v for k, v in _row(simulation, 1.0e9).items() if k not in later}

    with engine.begin() as connection:  # what demcal wrote at revision 0001
        connection.execute(insert(SimulationRow).values(row_0001(bad_parameters)))
        row = connection.execute(
            insert(SimulationRow).values(row_0001(earlier)).returning(SimulationRow.id)
        ).scalar_one()
        connection.execute(
            insert(ParameterRow),
            [
                {"simulation_id": row, "name": n, "value": q.value, "unit": q.unit, "free": False}
                for n, q in earlier_parameters.items()
            ],
        )
    engine.dispose()
    today = replace(
        earlier,
        parameters={
            "sliding_friction_pp": earlier_parameters["sliding_friction_pp"],
            "restitution_pp": Quantity(0.7, "-"),
            "restitution_pw": Quantity(0.7, "-"),
            "rolling_damping_ratio": Quantity(0.3, "-"),
            "particle_density": earlier_parameters["particle_density"],
            "surface_energy_pp": Quantity(0.0, "J/m^2"),
            "surface_energy_pw": Quantity(0.0, "J/m^2"),
            "d50": Quantity(SETTINGS["d50"], "m"),
            "sigma_ln": Quantity(SETTINGS["sigma_ln"], "-"),
        },
        free=frozenset(),
    )
    failed_today = replace(
        bad_parameters,
        parameters={
            "d50": Quantity(SETTINGS["d50"], "m"),
            "sigma_ln": Quantity(SETTINGS["sigma_ln"], "-"),
        },
    )
    with Archive(archive_url) as archive:
        failed, migrated = archive.records()
        assert migrated.parameters == today.parameters
        assert migrated.key == today.key and migrated.settings_hash == today.settings_hash
        assert failed.key == failed_today.key and "rolling_damping_ratio" not in failed.parameters
        assert "surface_energy_pp" not in failed.parameters
        assert archive.add([today, failed_today]) == 0
        settings = {n: v for n, v in SETTINGS.items() if n not in ("d50", "sigma_ln")}
        fixed = {n: q.value for n, q in today.parameters.items() if n != "sliding_friction_pp"}
        # demcal did not record what simulated them then (0003): no study reuses them
        assert migrated.simulator == ""
        assert (
            archive.compatible(
                "cylinder_lift",
                "analytic",
                settings,
                fixed,
                ["sliding_friction_pp"],
                simulator=SIMULATOR,
            )
            == []
        )
    assert today.key != earlier.key  # the key was spelled again


def test_runs_stored_before_adhesion_stay_compatible_as_cohesionless(archive_url):
    """Migration 0005: a simulation stored at revision 0004 gets both surface energies at 0,
    so a study of today's (whose fixed material holds them) still reuses it, and its key is
    the one the same simulation gets today."""
    from demcal.archive.store import _row, upgrade

    earlier = record(5)
    engine = open_engine(archive_url)
    upgrade(engine, "0004")
    with engine.begin() as connection:
        row = connection.execute(
            insert(SimulationRow).values(_row(earlier, 1.0e9)).returning(SimulationRow.id)
        ).scalar_one()
        connection.execute(
            insert(ParameterRow),
            [
                {"simulation_id": row, "name": n, "value": q.value, "unit": q.unit, "free": False}
                for n, q in earlier.parameters.items()
            ],
        )
    engine.dispose()
    cohesionless = {"surface_energy_pp": Quantity(0.0, "J/m^2")}
    cohesionless["surface_energy_pw"] = Quantity(0.0, "J/m^2")
    today = replace(earlier, parameters={**earlier.parameters, **cohesionless})
    with Archive(archive_url) as archive:
        (migrated,) = archive.records()
        assert migrated.parameters == today.parameters and migrated.key == today.key
        assert archive.add([today]) == 0
        fixed = {"restitution_pp": 0.5, "particle_density": 2500.0}
        found = archive.compatible(
            "cylinder_lift",
            "analytic",
            dict(SETTINGS),
            {**fixed, "surface_energy_pp": 0.0, "surface_energy_pw": 0.0},
            ["sliding_friction_pp"],
            simulator=SIMULATOR,
        )
        assert [r.key for r in found] == [today.key]


def test_an_archive_of_a_newer_demcal_is_refused(archive_url):
    Archive(archive_url).close()
    engine = open_engine(archive_url)
    with engine.begin() as connection:
        connection.execute(text(f"UPDATE {VERSION_TABLE} SET version_num = 'ffff'"))
    engine.dispose()
    with pytest.raises(ArchiveError, match="newer than this demcal"):
        Archive(archive_url)


def test_an_unreachable_archive_is_one_message(tmp_path):
    (tmp_path / "folder").mkdir()
    with pytest.raises(ArchiveError, match="cannot be opened"):
        Archive(f"sqlite:///{tmp_path / 'folder'}")


def test_a_database_error_while_reading_is_one_message(tmp_path):
    url = f"sqlite:///{tmp_path / 'archive.sqlite'}"
    with Archive(url) as archive:
        archive.add([record(0)])
        engine = open_engine(url)
        with engine.begin() as connection:  # a table gone behind the archive's back
            connection.execute(text("DROP TABLE responses"))
        engine.dispose()
        with pytest.raises(ArchiveError, match="archive sqlite:///.*no such table: responses"):
            archive.records()


def test_stats_count_and_cost_per_study_scene_and_status(archive_url):
    with Archive(archive_url) as archive:
        archive.add([record(0), record(1), replace(record(2), status=Status.FAILED)])
        rows = archive.stats()
    assert [(r["status"], r["simulations"], r["cpu_s"]) for r in rows] == [
        ("failed", 1, 1.5),
        ("ok", 2, 3.0),
    ]
