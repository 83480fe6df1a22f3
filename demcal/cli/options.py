"""Options shared by the commands: checked numbers (a value outside its range is refused by the
parser, in one line that names the option and gives the range), and the former spelling of a
renamed option, still accepted."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

from demcal.snakemake_command import LOCAL_PROFILE

#: The largest integer a SQL database stores (SQLite's and PostgreSQL's BIGINT): a simulation's
#: number in the archive, a row limit.
LARGEST_ROW = 2**63 - 1
#: The most simulations one command may ask for (``--explore``, ``--validate``).
MOST_SIMULATIONS = 1000
#: Longest bad value quoted in a message.
SHOWN_CHARS = 40
#: The metavar of the options that take free-parameter values; the parser tells a study's
#: name that follows them from the values (``demcal solutions --point a=1 b=2 STUDY``).
ASSIGNMENT = "NAME=VALUE"


def whole_number(low: int, high: int) -> Callable[[str], int]:
    """An argparse ``type``: a whole number from ``low`` to ``high``; any other text is
    refused with that range."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:  # "1e20", "two", more digits than int() reads
            value = low - 1
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(
                f"{quoted(text)} is not a whole number from {low} to {high}"
            )
        return value

    return parse


def former_name(sub: argparse.ArgumentParser, old: str, new: str, **kwargs: Any) -> None:
    """Accept ``old``, the former name of option ``new``, for the same value (``kwargs``: its
    ``type``, ``nargs``); left out of the help."""
    sub.add_argument(
        old,
        dest=new.lstrip("-").replace("-", "_"),
        default=argparse.SUPPRESS,  # the new option's default stands
        help=argparse.SUPPRESS,
        **kwargs,
    )


def quoted(text: str) -> str:
    """``text`` as a message quotes it: in quotes, cut to SHOWN_CHARS characters."""
    if len(text) <= SHOWN_CHARS:
        return repr(text)
    return f"{text[:SHOWN_CHARS]!r}... ({len(text)} characters)"


def profile_argument(sub: argparse.ArgumentParser, what: str = "simulations") -> None:
    """``--profile``: the Snakemake profile that runs a command's ``what``."""
    sub.add_argument(
        "--profile",
        default=str(LOCAL_PROFILE),
        help=f"Snakemake profile of the {what} (default: demcal's profiles/local)",
    )


def evaluation_arguments(sub: argparse.ArgumentParser) -> None:
    sub.add_argument(
        "--profile",
        default=str(LOCAL_PROFILE),
        help="Snakemake profile directory for the evaluations (default: demcal's profiles/local)",
    )
    sub.add_argument("--workers", type=int, help="evaluations in flight")
