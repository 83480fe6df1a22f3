"""``demcal psd fit SIEVE.csv``: GGS, RRSB and LOGN fitted to a sieve analysis.

The CSV file has a header line naming the columns ``d_mm`` (sieve aperture in
mm) and ``Q3_percent`` (cumulative mass passing that sieve, in %); other
columns are ignored, lines starting with ``#`` are comments, and the sieves may
come in either order. It is UTF-8, with or without the byte-order mark that
spreadsheets write, a regular file of at most :data:`MAX_BYTES` in lines of at
most :data:`MAX_LINE_CHARS`. The LOGN fit is printed as the ``d50`` [m] and
``sigma_ln`` of a study's scene settings.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import stat
from pathlib import Path

import numpy as np

from demcal.errors import ConfigError
from demcal.physics.psd import diameter_range, sampled_q3
from demcal.physics.sieve import Fit, fit_all, number_median, r_squared

SIZE = "d_mm"
PASSING = "Q3_percent"
#: psd_truncation values checked: the shear box's default, the other scenes', and a wide cut.
TRUNCATIONS = (1.5, 2.0, 3.0)
COLUMNS = f"{SIZE} (sieve aperture, mm) and {PASSING} (cumulative mass passing, %)"
#: Bytes a sieve file may hold: a sieve analysis is a few dozen lines, a few kB.
MAX_BYTES = 1_000_000
#: Characters a line of a sieve file may hold.
MAX_LINE_CHARS = 1000


def arguments(sub: argparse.ArgumentParser) -> None:
    """The actions of ``demcal psd``."""
    actions = sub.add_subparsers(dest="action", required=True)
    fitting = actions.add_parser(
        "fit",
        help="fit GGS, RRSB and LOGN (Richter & Will 2021, eqs. 1-3) to sieve data",
        description=f"Fit GGS, RRSB and LOGN to a sieve analysis. SIEVE.csv: a header line "
        f"with the columns {COLUMNS}, one line per sieve; lines starting with # are comments.",
    )
    fitting.add_argument(
        "sieve", type=Path, metavar="SIEVE.csv", help=f"columns {COLUMNS}".replace("%", "%%")
    )


def read_sieve(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Apertures [mm], ascending, and fractions passing [0, 1] of a sieve CSV file; any defect
    is a ConfigError naming the file, line and column."""
    lines = []
    for number, line in enumerate(sieve_text(path).splitlines(), start=1):
        if len(line) > MAX_LINE_CHARS:
            raise ConfigError(
                f"{path}, line {number}: {len(line)} characters; a line of a sieve file holds "
                f"at most {MAX_LINE_CHARS}"
            )
        if line.strip() and not line.lstrip().startswith("#"):
            lines.append((number, line))
    if not lines:
        raise ConfigError(f"{path}: empty; expected a header line with the columns {COLUMNS}")
    header_line, header_text = lines[0]
    header = [name.strip() for name in next(csv.reader([header_text]))]
    for name in (SIZE, PASSING):
        if name not in header:
            raise ConfigError(
                f"{path}, line {header_line}: no column {name!r} in the header "
                f"({', '.join(header)}); expected {COLUMNS}"
            )
    rows = []
    for number, line in lines[1:]:
        fields = next(csv.reader([line]))
        size, passing = (
            number_in(fields, header.index(name), f"{path}, line {number}, column {name}")
            for name in (SIZE, PASSING)
        )
        if not size > 0.0:
            raise ConfigError(f"{path}, line {number}, column {SIZE}: {size:g} mm must be > 0")
        if not 0.0 <= passing <= 100.0:
            raise ConfigError(
                f"{path}, line {number}, column {PASSING}: {passing:g} % must be within 0-100"
            )
        rows.append((size, passing, number))
    return checked(path, sorted(rows))


def sieve_text(path: Path) -> str:
    """The text of a sieve file: a regular file of at most MAX_BYTES in UTF-8, without the
    byte-order mark a spreadsheet's "CSV UTF-8" starts with. Opened without waiting, so that
    a pipe is refused, not waited on."""
    try:
        descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
        if not stat.S_ISREG(os.fstat(descriptor).st_mode):
            os.close(descriptor)
            raise ConfigError(
                f"{path}: not a regular file (a folder, device or pipe); give the sieve "
                "analysis as a CSV file"
            )
        with open(descriptor, "rb") as file:
            data = file.read(MAX_BYTES + 1)
        if len(data) > MAX_BYTES:
            raise ConfigError(
                f"{path}: larger than {MAX_BYTES / 1e6:g} MB, the most a sieve file may hold "
                "(a sieve analysis is a few dozen lines)"
            )
        return data.decode("utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read the sieve file {path}: {exc}") from None


def number_in(fields: list[str], column: int, where: str) -> float:
    """The finite number in ``fields[column]``."""
    if column >= len(fields):
        raise ConfigError(f"{where}: missing (the line has {len(fields)} fields)")
    try:
        value = float(fields[column])
    except ValueError:
        raise ConfigError(f"{where}: {fields[column].strip()!r} is not a number") from None
    if not math.isfinite(value):
        raise ConfigError(f"{where}: {value:g} is not a finite number")
    return value


def checked(path: Path, rows: list[tuple[float, float, int]]) -> tuple[np.ndarray, np.ndarray]:
    """The sorted rows (aperture, % passing, line) as arrays, once they can determine a fit."""
    if len(rows) < 3:
        raise ConfigError(f"{path}: {len(rows)} sieves; a fit needs at least 3")
    for (d0, q0, line0), (d1, q1, line1) in zip(rows, rows[1:]):
        if d1 == d0:
            raise ConfigError(
                f"{path}, line {line1}, column {SIZE}: {d1:g} mm twice (line {line0})"
            )
        if q1 < q0:
            raise ConfigError(
                f"{path}, line {line1}, column {PASSING}: {q1:g} % passes {d1:g} mm but {q0:g} % "
                f"passes the smaller {d0:g} mm (line {line0}); cumulative passing cannot fall"
            )
    d = np.array([row[0] for row in rows])
    q = np.array([row[1] for row in rows])
    if q.max() <= 1.0:
        raise ConfigError(f"{path}, column {PASSING}: every value is <= 1: give %, not fractions")
    if len(set(q[(q > 0.0) & (q < 100.0)])) < 2:
        raise ConfigError(
            f"{path}, column {PASSING}: a fit needs at least two sieves that pass different "
            "shares between 0 and 100 %"
        )
    return d, q / 100.0


def table(fits: list[Fit]) -> list[str]:
    """One line per fit, best first: parameters, R² and MSE."""
    lines = [f"{'rank':<5}{'function':<10}{'parameters':<34}{'R²':>8}{'MSE':>11}"]
    for rank, f in enumerate(fits, start=1):
        parameters = f"{f.size_name} = {f.size:.4g} mm, {f.shape_name} = {f.shape:.3g}"
        lines.append(f"{rank:<5}{f.function:<10}{parameters:<34}{f.r2:>8.4f}{f.mse:>11.2e}")
    return lines


def snippet(path: Path, lognormal: Fit, d: np.ndarray, q: np.ndarray) -> list[str]:
    """The LOGN fit as the ``d50`` [m] and ``sigma_ln`` of a study's scene settings, and how
    well the spheres the scenes sample from them fit the sieves at some ``psd_truncation``."""
    sigma = lognormal.shape
    d50 = number_median(lognormal.size, sigma)
    cuts = []
    for k in TRUNCATIONS:
        low, high = diameter_range(d50, sigma, k)
        r2 = r_squared(q, sampled_q3(d, d50, sigma, k))
        cuts.append(f"R² {r2:.4f} at {k:g} ({low:.3g}-{high:.3g} mm)")
    return [
        f"# LOGN fit of {path.name}; paste into scenes: <scene>: settings:",
        f"# d50 by number (demcal samples spheres by number) = mass median "
        f"{lognormal.size:.4g} mm x exp(-3 sigma_ln^2)",
        f"d50: {d50 / 1000.0:.4g}   # m",
        f"sigma_ln: {sigma:.3g}",
        "# the scenes cut it at psd_truncation sigma_ln; their spheres' Q3 then fits the sieves",
        f"# with {', '.join(cuts)}",
    ]


def psd(args: argparse.Namespace) -> int:
    d, q = read_sieve(args.sieve)
    fits = fit_all(d, q)
    print(
        f"{args.sieve}: {len(d)} sieves, {d[0]:g}-{d[-1]:g} mm; least squares on Q3 "
        "(Richter & Will 2021, eqs. 1-3), MSE of Q3 as a fraction"
    )
    print("\n".join(table(fits)))
    print()
    lognormal = next(f for f in fits if f.function == "LOGN")
    print("\n".join(snippet(args.sieve, lognormal, d, q)))
    return 0
