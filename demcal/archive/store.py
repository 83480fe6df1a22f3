"""The archive: every simulation demcal runs, with its provenance, in one database.

::

    with Archive("sqlite:///results/archive.sqlite") as archive:
        archive.add(records)                     # idempotent: a record already there is skipped
        archive.records(scene="cylinder_lift")   # what is stored, oldest first
        archive.compatible(...)                  # what a study may reuse as data

Opening an archive brings its schema to this demcal's version (Alembic, ``upgrade``) under
a lock, so the first jobs of a new archive may open it at once. Each ``add`` is one
transaction: its records are all there afterwards, or none is. A record whose key
(`ArchivedSimulation.key`) is stored already is skipped (``INSERT ... ON CONFLICT DO
NOTHING``), so a retried job or a second import adds nothing, and concurrent writers never
store a simulation twice.

A damaged row (a NaN or text response, a JSON column that is not JSON, an unknown status) never
stops a read: the record is read without the damaged values, or left out when what ran or how
it ended is unknown (`_record`), and `Archive.warn_damaged` names them in one line.
"""

from __future__ import annotations

import json
import math
import sys
import time
from collections.abc import Callable, Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass
from functools import cache, wraps
from pathlib import Path
from types import TracebackType
from typing import Any, Concatenate, ParamSpec, TypeVar

from sqlalchemy import (
    JSON,
    Connection,
    Engine,
    Row,
    RowMapping,
    Select,
    Text,
    cast,
    exists,
    func,
    insert,
    select,
    text,
)
from sqlalchemy.dialects import postgresql, sqlite
from sqlalchemy.exc import SQLAlchemyError

from demcal.archive.schema import Base, ParameterRow, ResponseRow, SimulationRow
from demcal.archive.simulation import ArchivedSimulation, Quantity, digest
from demcal.errors import DemcalError
from demcal.results.archive_url import open_engine, shown
from demcal.results.records import Status

P = ParamSpec("P")
R = TypeVar("R")

#: The migration scripts shipped in the package (env.py and versions/).
MIGRATIONS = Path(__file__).resolve().parent / "migrations"
#: The table in which Alembic keeps the archive's schema version.
VERSION_TABLE = "archive_version"
#: Key of the PostgreSQL advisory lock held while a schema is migrated ("demcal" in ASCII).
MIGRATION_LOCK = 0x64656D63616C


class ArchiveError(DemcalError):
    """The archive cannot be opened or read; the message names it and why."""


@cache
def head_revision() -> str:
    """The schema version this demcal writes (the newest migration)."""
    from alembic.script import ScriptDirectory

    head = ScriptDirectory(str(MIGRATIONS)).get_current_head()
    assert head is not None, "the archive's migrations have no head"
    return head


def schema_revision(connection: Connection) -> str | None:
    """The schema version of the database at ``connection`` (None: no archive there yet)."""
    from alembic.migration import MigrationContext

    context = MigrationContext.configure(connection, opts={"version_table": VERSION_TABLE})
    return context.get_current_revision()


def upgrade(engine: Engine, revision: str | None = None) -> None:
    """Bring the archive's schema to ``revision`` (default `head_revision`; the tests of
    a migration start from an earlier one), once among concurrent openers.

    The migration runs in one transaction that holds the database's write lock (SQLite's
    ``BEGIN IMMEDIATE``; a PostgreSQL advisory lock), and the version is read again under
    it, so a second opener waits and then finds nothing to do.
    """
    revision = revision or head_revision()
    with engine.connect() as connection:
        if schema_revision(connection) == revision:
            return
    from alembic import command
    from alembic.config import Config
    from alembic.util import CommandError

    with engine.execution_options(archive_write=True).begin() as connection:
        if connection.dialect.name == "postgresql":
            connection.execute(text("SELECT pg_advisory_xact_lock(:key)"), {"key": MIGRATION_LOCK})
        current = schema_revision(connection)
        if current == revision:
            return
        config = Config()
        config.set_main_option("script_location", str(MIGRATIONS))
        config.attributes["connection"] = connection
        config.attributes["version_table"] = VERSION_TABLE
        try:
            command.upgrade(config, revision)
        except CommandError:  # a schema version that none of the migrations knows
            raise ArchiveError(f"its schema {current!r} is newer than this demcal's") from None


def drop(url: str) -> None:
    """Remove the archive's tables and its schema version from the database at ``url`` (the
    tests and the load benchmark start from an empty PostgreSQL database this way)."""
    engine = open_engine(url)
    with engine.begin() as connection:
        Base.metadata.drop_all(connection)
        connection.execute(text(f"DROP TABLE IF EXISTS {VERSION_TABLE}"))
    engine.dispose()


def _number(value: Any) -> float | None:
    return float(value) if isinstance(value, int | float) and not isinstance(value, bool) else None


def number_flaw(what: str, value: object) -> str | None:
    """Why ``value``, the ``what`` of a simulation, cannot be used as one of its numbers (text,
    NaN, infinite; None if it can)."""
    number = _number(value)
    return (
        None
        if number is not None and math.isfinite(number)
        else f"{what} is {value!r}, not a finite number"
    )


@dataclass(frozen=True)
class Damage:
    """What was wrong with a stored simulation when it was read: its ``flaws``, and whether
    its record was ``skipped`` or read without the damaged values."""

    flaws: tuple[str, ...]
    skipped: bool


def _reported(method: Callable[Concatenate[Archive, P], R]) -> Callable[Concatenate[Archive, P], R]:
    """An archive method whose database errors (a lock held too long, a lost connection, a
    row the database refuses) end as one ArchiveError naming the archive."""

    @wraps(method)
    def reported(archive: Archive, /, *args: P.args, **kwargs: P.kwargs) -> R:
        try:
            return method(archive, *args, **kwargs)
        except SQLAlchemyError as exc:
            raise ArchiveError(f"archive {shown(archive.url)}: {_first_line(exc)}") from exc

    return reported


class Archive:
    """The archive at ``url`` (an SQLite file or a PostgreSQL database), opened and brought to
    this demcal's schema. Use it as a context manager, or ``close`` it."""

    def __init__(self, url: str):
        self.url = url
        self._engine = open_engine(url)
        try:
            upgrade(self._engine)
        except SQLAlchemyError as exc:
            self._engine.dispose()
            raise ArchiveError(
                f"archive {shown(url)}: cannot be opened ({_first_line(exc)})"
            ) from exc
        except ArchiveError as exc:
            self._engine.dispose()
            raise ArchiveError(f"archive {shown(url)}: {exc}; update demcal") from None
        self._writer = self._engine.execution_options(archive_write=True)
        #: The damaged simulations read since the last `warn_damaged`, by id.
        self.damaged: dict[int, Damage] = {}

    def __enter__(self) -> Archive:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

    def close(self) -> None:
        self._engine.dispose()

    def __repr__(self) -> str:
        return f"Archive({shown(self.url)!r})"

    # writing

    @_reported
    def add(self, records: Iterable[ArchivedSimulation]) -> int:
        """Store ``records`` in one transaction; those already stored are skipped. Returns how
        many were new."""
        dialect = sqlite if self._engine.dialect.name == "sqlite" else postgresql
        now, added = time.time(), 0
        with self._writer.begin() as connection:
            for record in records:
                new_id = connection.execute(
                    dialect.insert(SimulationRow)
                    .values(_row(record, now))
                    .on_conflict_do_nothing(index_elements=["key"])
                    .returning(SimulationRow.id)
                ).scalar_one_or_none()
                if new_id is None:
                    continue
                added += 1
                parameters = [
                    {"simulation_id": new_id, "name": name, "value": q.value, "unit": q.unit}
                    | {"free": name in record.free}
                    for name, q in record.parameters.items()
                ]
                responses = [
                    {"simulation_id": new_id, "name": name, "value": q.value, "unit": q.unit}
                    | {"final": record.final.get(name, False)}
                    for name, q in record.responses.items()
                ]
                if parameters:
                    connection.execute(insert(ParameterRow), parameters)
                if responses:
                    connection.execute(insert(ResponseRow), responses)
        return added

    # reading

    @_reported
    def records(
        self,
        *,
        study: str | None = None,
        scene: str | None = None,
        engine: str | None = None,
        evaluation: str | None = None,
        statuses: Collection[str] = (),
        limit: int | None = None,
    ) -> list[ArchivedSimulation]:
        """The stored simulations that match every filter given, oldest first."""
        query = select(SimulationRow.id)
        for column, value in (
            (SimulationRow.study, study),
            (SimulationRow.scene, scene),
            (SimulationRow.engine, engine),
            (SimulationRow.evaluation, evaluation),
        ):
            if value is not None:
                query = query.where(column == value)
        if statuses:
            query = query.where(SimulationRow.status.in_(list(statuses)))
        return self._load(query.order_by(SimulationRow.id).limit(limit))

    @_reported
    def get(self, identifier: str) -> ArchivedSimulation | None:
        """The simulation with this row number, or whose key starts with ``identifier`` (at
        least 6 characters and only one such key); None if there is none."""
        if identifier.isdigit():
            found = self._load(select(SimulationRow.id).where(SimulationRow.id == int(identifier)))
        elif len(identifier) >= 6:
            found = self._load(
                select(SimulationRow.id).where(
                    SimulationRow.key.startswith(identifier.lower(), autoescape=True)
                )
            )
        else:
            found = []
        return found[0] if len(found) == 1 else None

    @_reported
    def compatible(
        self,
        scene: str,
        engine: str,
        settings: dict[str, Any],
        fixed: Mapping[str, float],
        inputs: Collection[str] = (),
        *,
        simulator: str,
        statuses: Collection[str] = (Status.OK,),
    ) -> list[ArchivedSimulation]:
        """The stored simulations a study may use as data for its models of ``scene``.

        Compatible means: the same scene, engine, ``simulator`` (the digest of what simulated
        it: `ArchivedSimulation.simulator`; a record that does not know its simulator
        matches none) and ``settings`` (those the archive does not keep as parameters:
        [`ArchivedSimulation.settings_hash`][demcal.archive.simulation.ArchivedSimulation.settings_hash]);
        exactly the parameters ``fixed`` and ``inputs`` (the models' inputs, the free
        parameters and any fixed one the models take as input), with every fixed parameter
        that is not an input at its value; a status in ``statuses``.
        """
        names = set(fixed) | set(inputs)
        query = select(SimulationRow.id).where(
            SimulationRow.scene == scene,
            SimulationRow.engine == engine,
            SimulationRow.simulator == simulator,
            SimulationRow.simulator != "",
            SimulationRow.settings_hash == digest(settings),
            SimulationRow.status.in_(list(statuses)),
        )
        for name in sorted(names):
            condition = (ParameterRow.simulation_id == SimulationRow.id) & (
                ParameterRow.name == name
            )
            if name in fixed and name not in inputs:
                condition &= ParameterRow.value == float(fixed[name])
            query = query.where(exists().where(condition))
        other = exists().where(
            (ParameterRow.simulation_id == SimulationRow.id) & ParameterRow.name.not_in(names)
        )
        return self._load(query.where(~other).order_by(SimulationRow.id))

    @_reported
    def count(self) -> int:
        with self._engine.connect() as connection:
            return int(connection.execute(select(func.count(SimulationRow.id))).scalar_one())

    @_reported
    def stats(self) -> list[dict[str, Any]]:
        """Per study, scene, engine and status: the simulations stored and their cost (the
        engine's cpu_s and particle_steps; None where no simulation of the group has one).
        Damaged simulations count as [`records`][demcal.archive.store.Archive.records] reads
        them."""
        groups: dict[tuple[str, ...], dict[str, Any]] = {}
        for record in self.records():
            group = (record.study, record.scene, record.engine, str(record.status))
            row = groups.setdefault(
                group,
                dict(zip(("study", "scene", "engine", "status"), group))
                | {"simulations": 0, "cpu_s": None, "particle_steps": None},
            )
            row["simulations"] += 1
            for figure in ("cpu_s", "particle_steps"):
                value = _number(record.cost.get(figure))
                if value is not None:
                    row[figure] = (row[figure] or 0.0) + value
        return [groups[group] for group in sorted(groups)]

    def damage_summary(self) -> str | None:
        """The damaged simulations read since the last
        [`warn_damaged`][demcal.archive.store.Archive.warn_damaged] in one line: how many, which ids
        and why (None: there were none)."""
        if not self.damaged:
            return None
        parts = []
        for skipped, done in ((True, "skipped"), (False, "left damaged values out of")):
            reasons: dict[str, list[str]] = {}
            for i, damage in sorted(self.damaged.items()):
                if damage.skipped == skipped:
                    reasons.setdefault(" and ".join(damage.flaws), []).append(str(i))
            count = sum(len(ids) for ids in reasons.values())
            if count:
                named = [
                    f"{'id' if len(ids) == 1 else 'ids'} {_few(ids, ', ')}: {reason}"
                    for reason, ids in reasons.items()
                ]
                parts.append(
                    f"{done} {count} damaged simulation{'s' if count > 1 else ''} "
                    f"({_few(named, '; ')})"
                )
        return f"archive {shown(self.url)}: {', and '.join(parts)}"

    def warn_damaged(self) -> None:
        """Say [`damage_summary`][demcal.archive.store.Archive.damage_summary] on stderr as one
        warning line, if there is damage, and forget it (a later read names only what it
        finds)."""
        summary = self.damage_summary()
        if summary is not None:
            print(f"demcal: warning: {summary}", file=sys.stderr, flush=True)
        self.damaged.clear()

    def _load(self, ids: Select[tuple[int]]) -> list[ArchivedSimulation]:
        """The records of the simulations whose ids ``ids`` selects, in its order; a damaged
        one is read as `_record` says and noted in `damaged`."""
        chosen = ids.subquery()
        columns = [  # JSON as text: a damaged one is named, not raised while fetched
            cast(column, Text).label(column.name) if isinstance(column.type, JSON) else column
            for column in SimulationRow.__table__.columns
        ]
        with self._engine.connect() as connection:
            simulations = {
                row.id: row._mapping
                for row in connection.execute(
                    select(*columns).join_from(
                        SimulationRow, chosen, SimulationRow.id == chosen.c.id
                    )
                )
            }
            parameters: dict[int, list[Row[Any]]] = {}
            responses: dict[int, list[Row[Any]]] = {}
            for table, found in ((ParameterRow, parameters), (ResponseRow, responses)):
                for value in connection.execute(
                    select(table).where(table.simulation_id.in_(select(chosen.c.id)))
                ):
                    found.setdefault(value.simulation_id, []).append(value)
            order = list(connection.scalars(ids))
        records = []
        for i in order:
            record, flaws = _record(simulations[i], parameters.get(i, []), responses.get(i, []))
            if flaws:
                self.damaged[i] = Damage(tuple(flaws), skipped=record is None)
            if record is not None:
                records.append(record)
        return records


#: Fields of a record that are columns of its simulations row under the same name.
SAME_NAMED = (
    "study",
    "evaluation",
    "scene",
    "replicate",
    "attempt",
    "seed",
    "engine",
    "engine_version",
    "settings",
    "timestep_fraction",
    "reason",
    "cost",
    "started_at",
    "ended_at",
    "source",
    "demcal_version",
    "simulator",
    "fidelity",
    "fine_level",
)


def _row(record: ArchivedSimulation, now: float) -> dict[str, Any]:
    """The simulations row of a record."""
    return {name: getattr(record, name) for name in SAME_NAMED} | {
        "key": record.key,
        "settings_hash": record.settings_hash,
        "psd": {name: {"value": q.value, "unit": q.unit} for name, q in record.psd.items()},
        "status": str(record.status),
        "cpu_s": _number(record.cost.get("cpu_s")),
        "wall_s": _number(record.cost.get("wall_s")),
        "particle_steps": _number(record.cost.get("particle_steps")),
        "recorded_at": now,
    }


#: The statuses a stored simulation can have (the CHECK constraint of its table).
STORED_STATUSES = tuple(s.value for s in Status if s != Status.PENDING)
#: Numbers of a simulations row that its record cannot do without (None where allowed).
ROW_NUMBERS = (
    "replicate",
    "attempt",
    "seed",
    "timestep_fraction",
    "started_at",
    "ended_at",
    "recorded_at",
)


def _record(
    row: RowMapping, parameters: Sequence[Row[Any]], responses: Sequence[Row[Any]]
) -> tuple[ArchivedSimulation | None, list[str]]:
    """The record of a stored simulation (its JSON columns as text) and the flaws of a damaged
    one. A response or psd value that is not a finite number, or a psd that is not JSON, is
    left out of the record: the rest stays sound. Any other flaw (an unknown status, a
    parameter or provenance number that is not a finite number, settings or cost that are not
    JSON objects) leaves no record (None): what ran, or how it ended, is unknown."""
    fatal = [
        flaw
        for name in ROW_NUMBERS
        if row[name] is not None and (flaw := number_flaw(name, row[name]))
    ]
    fatal += [flaw for p in parameters if (flaw := number_flaw(f"parameter {p.name}", p.value))]
    if row["status"] not in STORED_STATUSES:
        fatal.append(f"status {row['status']!r} is not one of {', '.join(STORED_STATUSES)}")
    settings = _json_object("settings", row["settings"], fatal)
    cost = _json_object("cost", row["cost"], fatal)
    flaws: list[str] = []
    psd = {}
    for name, q in _json_object("psd", row["psd"], flaws).items():
        value: Any = q.get("value") if isinstance(q, dict) else q
        unit = q.get("unit") if isinstance(q, dict) else None
        flaw = number_flaw(f"psd {name}", value)
        if flaw is None and isinstance(unit, str):
            psd[name] = Quantity(value, unit)
        else:
            flaws.append(flaw or f"psd {name} has no unit")
    sound = []
    for r in responses:
        flaw = number_flaw(f"response {r.name}", r.value)
        if flaw is None:
            sound.append(r)
        else:
            flaws.append(flaw)
    if fatal:
        return None, fatal + flaws
    return ArchivedSimulation(
        **{name: row[name] for name in SAME_NAMED} | {"settings": settings, "cost": cost},
        status=Status(row["status"]),
        parameters={p.name: Quantity(p.value, p.unit) for p in parameters},
        free=frozenset(p.name for p in parameters if p.free),
        psd=psd,
        responses={r.name: Quantity(r.value, r.unit) for r in sound},
        final={r.name: r.final for r in sound},
        id=row["id"],
        recorded_at=row["recorded_at"],
    ), flaws


def _json_object(name: str, stored: object, flaws: list[str]) -> dict[str, Any]:
    """The JSON object of the column ``name`` as stored (text); {} if it is none, with the
    flaw added to ``flaws``."""
    try:
        value = json.loads(stored) if isinstance(stored, str) else None
    except ValueError:
        value = None
    if isinstance(value, dict):
        return value
    flaws.append(f"{name} is not a JSON object")
    return {}


def _few(items: list[str], separator: str, most: int = 10) -> str:
    """``items`` joined by ``separator``: the first ``most``, then how many more there are."""
    more = len(items) - most
    return separator.join(items[:most]) + (f"{separator}and {more} more" if more > 0 else "")


def _first_line(exc: BaseException) -> str:
    return str(getattr(exc, "orig", None) or exc).strip().splitlines()[0]
