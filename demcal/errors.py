"""Errors that reach a user as a message, never as a traceback."""


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
