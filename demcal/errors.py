"""Errors that reach a user as a message, never as a traceback."""


class DemcalError(Exception):
    """Base class: the message is meant for the user as it stands."""


class ConfigError(DemcalError):
    """The study configuration is invalid; the message names field, value and what is allowed."""


class SimulationFailed(DemcalError):
    """A simulation ended without usable results; the message is the recorded reason."""
