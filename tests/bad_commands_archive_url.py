"""Archive URLs of a scheme demcal cannot keep an archive in, given to ``--url`` (issue 35,
item 3): one line naming the option, never SQLAlchemy's plugin traceback. ``postgres://``, the
spelling SQLAlchemy dropped, is read as PostgreSQL (here a server that does not answer)."""

from __future__ import annotations

from bad_commands import BadCommand

URLS = {
    "http": ("http://host/archive", r"--url: http:// is not a database demcal can keep"),
    "file": ("file:///tmp/archive.sqlite", r"--url: file:// is not a database demcal can keep"),
    "postgres": (
        "postgres://user@127.0.0.1:1/archive",
        r"archive postgresql://user@127.0.0.1:1/archive: cannot be opened \(connection failed",
    ),
}

CASES = [
    BadCommand(f"archive_{command}_url_{scheme}", ("archive", command, "--url", url), message)
    for command in ("list", "stats")
    for scheme, (url, message) in URLS.items()
]
