"""Archive records and archives for the tests: an SQLite file, and a PostgreSQL database when
DEMCAL_TEST_POSTGRES_URL names one (.ci/run starts a server and sets it)."""

from __future__ import annotations

import os
from dataclasses import replace

import pytest

from demcal.archive.simulation import ArchivedSimulation, Quantity
from demcal.archive.store import drop
from demcal.results.records import Status

POSTGRES_URL = os.environ.get("DEMCAL_TEST_POSTGRES_URL")
SETTINGS = {"d50": 0.002, "sigma_ln": 0.1, "particle_count": 200}
#: The digest of the simulator of every record (``ArchivedSimulation.simulator``).
SIMULATOR = "a" * 64


def record(n: int = 0, **changes) -> ArchivedSimulation:
    """A simulation record, different for every ``n``."""
    base = ArchivedSimulation(
        study="unit",
        evaluation=f"e{n:04d}",
        scene="cylinder_lift",
        replicate=0,
        engine="analytic",
        engine_version="analytic-1",
        settings=SETTINGS,
        timestep_fraction=0.25,
        status=Status.OK,
        attempt=0,
        seed=1000 + n,
        parameters={
            "sliding_friction_pp": Quantity(0.1 + n * 1e-3, "-"),
            "restitution_pp": Quantity(0.5, "-"),
            "particle_density": Quantity(2500.0, "kg/m^3"),
        },
        free=frozenset({"sliding_friction_pp"}),
        psd={"d50": Quantity(0.002, "m"), "sigma_ln": Quantity(0.1, "-")},
        responses={
            "angle_of_repose": Quantity(25.0 + n, "deg"),
            "bulk_density": Quantity(1450.0, "kg/m^3"),
        },
        final={"angle_of_repose": True, "bulk_density": True},
        cost={"cpu_s": 1.5, "wall_s": 2.0, "particle_steps": 4.0e6},
        started_at=1.0e9,
        ended_at=1.0e9 + 2,
        demcal_version="0.1.0",
        simulator=SIMULATOR,
    )
    return replace(base, **changes)


def stored(found: ArchivedSimulation) -> ArchivedSimulation:
    """A record read back, without what the archive adds (its row number and time)."""
    return replace(found, id=None, recorded_at=None)


#: The databases every archive test runs on (the fixture ``archive_url`` of the test modules).
DATABASES = ("sqlite", "postgresql")


def new_archive(database: str, folder) -> str:
    """The URL of a new, empty archive: an SQLite file in ``folder``; the PostgreSQL database
    of DEMCAL_TEST_POSTGRES_URL emptied (the test is skipped without one)."""
    if database == "sqlite":
        return f"sqlite:///{folder / 'archive.sqlite'}"
    if POSTGRES_URL is None:
        pytest.skip("DEMCAL_TEST_POSTGRES_URL names no PostgreSQL server")
    drop(POSTGRES_URL)
    return POSTGRES_URL
