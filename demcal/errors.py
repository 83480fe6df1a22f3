"""Errors that reach a user as a message, never as a traceback."""

import difflib
from collections.abc import Iterable


class DemcalError(Exception):
    """Base class: the message is meant for the user as it stands."""


class ConfigError(DemcalError):
    """The study configuration is invalid; the message names field, value and what is allowed."""


class SimulationFailed(DemcalError):
    """A simulation ended without usable results; the message is the recorded reason."""


#: Longest failure reason a record keeps; the full text stays in the simulator's log.
REASON_CHARS = 600


def bounded_reason(text: str) -> str:
    """``text`` cut to about REASON_CHARS (its start and end kept), so that a flooding simulator
    cannot copy megabytes into every record that quotes its reason."""
    text = str(text)
    if len(text) <= REASON_CHARS:
        return text
    half = REASON_CHARS // 2
    return (
        f"{text[:half]} [... {len(text) - 2 * half} characters cut; see the log ...] {text[-half:]}"
    )


def unknown_field(name: str, allowed: Iterable[str]) -> str:
    """The message for a field ``name`` (its full path) that is not one of ``allowed``: the
    closest allowed name when it looks misspelt, else every allowed name."""
    allowed = sorted(allowed)
    close = difflib.get_close_matches(name.rsplit(".", 1)[-1], allowed, n=1)
    if close:
        return f"{name}: unknown field; did you mean {close[0]}?"
    return f"{name}: unknown field; allowed here: {', '.join(allowed) or 'none'}"
