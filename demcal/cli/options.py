"""Checked numbers on the command line: an option's value outside its range is refused by the
parser, in one line that names the option and gives the range."""

from __future__ import annotations

import argparse
from collections.abc import Callable

#: The largest integer a SQL database stores (SQLite's and PostgreSQL's BIGINT): a simulation's
#: number in the archive, a row limit.
LARGEST_ROW = 2**63 - 1
#: The most simulations one command may ask for (``--explore``, ``--validate``).
MOST_SIMULATIONS = 1000
#: Longest bad value quoted in a message.
SHOWN_CHARS = 40


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


def quoted(text: str) -> str:
    """``text`` as a message quotes it: in quotes, cut to SHOWN_CHARS characters."""
    if len(text) <= SHOWN_CHARS:
        return repr(text)
    return f"{text[:SHOWN_CHARS]!r}... ({len(text)} characters)"
