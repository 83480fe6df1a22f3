"""Bad uses of ``demcal sample`` and ``demcal psd fit`` (issue 35, items 5 and 6): designs
too large to plan, and sieve files that are huge, endless, not files at all, or one endless
line. Each is refused in one line naming ``--points`` or the file, with the allowed size."""

from __future__ import annotations

import copy
import os
from pathlib import Path

from bad_commands import SMALL_STUDY, STUDY_FILE, BadCommand, write_study

SIEVE_FILE = "sieve.csv"
HEADER = b"d_mm,Q3_percent\n"
#: Bytes of the huge sieve files: a hundred times what ``psd fit`` reads.
HUGE = 100_000_000


def huge_table(folder: Path) -> None:
    """A sieve file of 100 MB in ordinary lines (one sieve repeated)."""
    block = b"8,30\n" * 200_000
    with open(folder / SIEVE_FILE, "wb") as file:
        file.write(HEADER)
        for _ in range(HUGE // len(block)):
            file.write(block)


def huge_line(folder: Path) -> None:
    """A sieve file of 100 MB in one line, after its header: no line break anywhere."""
    with open(folder / SIEVE_FILE, "wb") as file:
        file.write(HEADER + b"8,")
        file.write(b"3" * HUGE)


def long_line(folder: Path) -> None:
    """A small sieve file (200 kB) whose third line is a 200 000-digit number."""
    (folder / SIEVE_FILE).write_bytes(HEADER + b"4,0\n8," + b"3" * 200_000 + b"\n16,100\n")


def fifo(folder: Path) -> None:
    """A named pipe where the sieve file should be: nothing ever writes to it."""
    os.mkfifo(folder / SIEVE_FILE)


def replicated_study(folder: Path) -> None:
    """The small study with 2 replicates: 2 simulations per point."""
    write_study(folder, {**copy.deepcopy(SMALL_STUDY), "replicates": 2})


CASES: list[BadCommand] = [
    BadCommand(
        "sample_a_billion_points",
        ("sample", STUDY_FILE, "--points", "1000000000"),
        r"--points 1000000000: give 2 to 5000 points",
        write_study,
    ),
    BadCommand(
        "sample_200000_points",
        ("sample", STUDY_FILE, "--points", "200000"),
        r"--points 200000: give 2 to 5000 points",
        write_study,
        timeout=30,
    ),
    BadCommand(
        "sample_5000_points_of_2_simulations",
        ("sample", STUDY_FILE, "--points", "5000"),
        r"--points 5000: give 2 to 2500 points .*at most 5000 simulations, here 2 per point",
        replicated_study,
        timeout=15,
    ),
    BadCommand(
        "psd_fit_100_mb_table",
        ("psd", "fit", SIEVE_FILE),
        r"sieve\.csv: larger than 1 MB",
        huge_table,
        timeout=30,
    ),
    BadCommand(
        "psd_fit_100_mb_line",
        ("psd", "fit", SIEVE_FILE),
        r"sieve\.csv: larger than 1 MB",
        huge_line,
        timeout=30,
    ),
    BadCommand(
        "psd_fit_200_kb_line",
        ("psd", "fit", SIEVE_FILE),
        r"sieve\.csv, line 3: 200002 characters; .* at most 1000",
        long_line,
    ),
    BadCommand(
        "psd_fit_dev_zero",
        ("psd", "fit", "/dev/zero"),
        r"/dev/zero: not a regular file",
        timeout=30,
    ),
    BadCommand(
        "psd_fit_named_pipe",
        ("psd", "fit", SIEVE_FILE),
        r"sieve\.csv: not a regular file",
        fifo,
        timeout=15,
    ),
]
