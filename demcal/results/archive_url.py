"""Where an archive lives: its URL, checked, and the database engine that opens it.

An archive is an SQLite file (``sqlite:///path/to/archive.sqlite``, a path relative to the
folder demcal runs in, like ``results/``) or a PostgreSQL database
(``postgresql://user:password@host:5432/name``, driven by psycopg 3). The default, one file
beside the studies of a project, is the study schema's (``archive.url``).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from demcal.errors import ConfigError

if TYPE_CHECKING:
    from sqlalchemy import Engine

#: Seconds an SQLite writer waits for another writer's lock before giving up.
SQLITE_BUSY_SECONDS = 60.0
#: Seconds a PostgreSQL connection attempt may take (an unreachable server fails the write).
CONNECT_SECONDS = 10

EXAMPLES = "sqlite:///results/archive.sqlite or postgresql://user@host:5432/database"


def check_url(text: object, where: str = "archive.url") -> str:
    """``text`` if it is an SQLite file or PostgreSQL URL (``postgres://`` spelled
    ``postgresql://``); else a ConfigError naming ``where`` and what is allowed."""
    # SQLAlchemy is imported on first use, here and below: a study without an archive, or a
    # refused one, does not pay for it
    from sqlalchemy.engine import make_url
    from sqlalchemy.exc import ArgumentError

    if not isinstance(text, str) or not text.strip():
        raise ConfigError(f"{where}: {text!r} is not a database URL; give one like {EXAMPLES}")
    try:
        url = make_url(text)
        url.port  # noqa: B018  (a port that is not a number raises here)
    except (ArgumentError, ValueError):
        raise ConfigError(
            f"{where}: {text!r} is not a database URL; give one like {EXAMPLES}"
        ) from None
    # the scheme is read as written: asking SQLAlchemy for the backend loads its plugin,
    # which fails with an ImportError-like traceback for http://, file://, ...
    backend, _, driver = url.drivername.partition("+")
    if backend == "postgres":  # the common spelling that SQLAlchemy 1.4 dropped
        backend = "postgresql"
        url = url.set(drivername="+".join(filter(None, (backend, driver))))
        text = url.render_as_string(hide_password=False)
    driver = driver or backend
    if backend == "sqlite":
        if url.drivername not in ("sqlite", "sqlite+pysqlite"):
            raise ConfigError(
                f"{where}: driver {driver!r} is not installed with demcal; write sqlite:///..."
            )
        if not url.database or url.database == ":memory:":
            raise ConfigError(
                f"{where}: {text!r} names no file; an archive in memory is gone when the job "
                f"ends; give a file, e.g. sqlite:///results/archive.sqlite"
            )
    elif backend == "postgresql":
        if url.drivername not in ("postgresql", "postgresql+psycopg"):
            raise ConfigError(
                f"{where}: driver {driver!r} is not installed with demcal; write "
                f"postgresql://... (demcal uses psycopg 3)"
            )
        if not url.database:
            raise ConfigError(f"{where}: {text!r} names no database (postgresql://host/NAME)")
    else:
        raise ConfigError(
            f"{where}: {backend}:// is not a database demcal can keep an archive in; give an "
            f"SQLite file or a PostgreSQL URL, like {EXAMPLES}"
        )
    return text


def missing_file(url: str) -> Path | None:
    """The file of an SQLite archive at ``url`` (checked) that does not exist yet; None when
    the file exists or the archive is a PostgreSQL database."""
    from sqlalchemy.engine import make_url

    parsed = make_url(check_url(url))
    if parsed.get_backend_name() != "sqlite" or parsed.database is None:
        return None
    path = Path(parsed.database)
    return None if path.exists() else path


def shown(url: str) -> str:
    """The URL without its password, for messages and logs."""
    from sqlalchemy.engine import make_url

    return make_url(url).render_as_string(hide_password=True)


def open_engine(url: str) -> Engine:
    """A SQLAlchemy engine on the archive at ``url`` (checked); an SQLite file's folder is
    made. SQLite writes take the database's write lock when their transaction begins
    (``BEGIN IMMEDIATE``), so concurrent writers queue for up to SQLITE_BUSY_SECONDS
    instead of failing on a lock upgrade; reads begin a plain transaction."""
    from sqlalchemy import create_engine
    from sqlalchemy.engine import make_url
    from sqlalchemy.pool import NullPool

    parsed = make_url(check_url(url))
    if parsed.get_backend_name() == "sqlite":
        assert parsed.database is not None  # check_url refused a URL without a file
        Path(parsed.database).parent.mkdir(parents=True, exist_ok=True)
        engine = create_engine(
            parsed, connect_args={"timeout": SQLITE_BUSY_SECONDS}, poolclass=NullPool
        )
        _sqlite_transactions(engine)
        return engine
    if parsed.drivername == "postgresql":
        parsed = parsed.set(drivername="postgresql+psycopg")
    return create_engine(
        parsed, connect_args={"connect_timeout": CONNECT_SECONDS}, pool_pre_ping=True
    )


def _sqlite_transactions(engine: Engine) -> None:
    """Let SQLAlchemy, not Python's sqlite3 module, begin SQLite's transactions (the recipe of
    SQLAlchemy's SQLite dialect documentation), a writer's as ``BEGIN IMMEDIATE``."""
    from sqlalchemy import event

    @event.listens_for(engine, "connect")
    def connect(dbapi_connection: Any, _record: Any) -> None:
        dbapi_connection.isolation_level = None  # no implicit BEGIN by the sqlite3 module
        cursor = dbapi_connection.cursor()
        cursor.execute("PRAGMA foreign_keys = ON")
        cursor.close()

    @event.listens_for(engine, "begin")
    def begin(connection: Any) -> None:
        immediate = connection.get_execution_options().get("archive_write", False)
        connection.exec_driver_sql("BEGIN IMMEDIATE" if immediate else "BEGIN")
