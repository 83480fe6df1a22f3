"""A sieve analysis of a gravel 8/16-like material: config/examples/sieve_gravel_8_16.csv.

    python benchmarks/sieve_gravel_8_16.py [--seed 2021] [--out FILE]

Richter & Will (2021) print no sieve table for their gravel 8/16, only its
lognormal fit (Table 3: mass median d50 11.16 mm, sigma_ln 0.26). This
script writes (by default to the file above) what a lab sheet of that material could read:

- the sieves: the ISO 3310-1 apertures from 4 to 22.4 mm (EN 933-2's series
  with its R20 intermediates);
- Q3 at each sieve from the paper's LOGN (their eq. 3), plus a normal error
  whose standard deviation is ASTM C136's single-operator repeatability of
  a coarse aggregate's % passing (its precision table: from 0.27 %-points
  near 0 or 100 % up to 2.25 between 60 and 80 %);
- as on a lab sheet, a sieve never passes less than the one below it, the
  values stay within 0-100 and are given in % to one decimal.

The same seed writes the same file.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from demcal.physics.sieve import logn

MASS_MEDIAN_MM = 11.16
SIGMA_LN = 0.26
APERTURES_MM = np.array([4.0, 5.6, 6.3, 8.0, 10.0, 11.2, 12.5, 14.0, 16.0, 20.0, 22.4])

#: ASTM C136, coarse aggregate, single-operator standard deviation of % passing, by the band
#: of % passing it applies to: (lower bound of the band [%], standard deviation [%-points]).
REPEATABILITY = (
    (95.0, 0.32),
    (85.0, 0.81),
    (80.0, 1.34),
    (60.0, 2.25),
    (20.0, 1.32),
    (15.0, 0.96),
    (10.0, 1.00),
    (5.0, 0.75),
    (2.0, 0.53),
    (0.0, 0.27),
)


def repeatability(passing: float) -> float:
    """Standard deviation [%-points] of a sieve analysis that passes ``passing`` %."""
    return next(sd for lower, sd in REPEATABILITY if passing >= lower)


def sieve_sheet(rng: np.random.Generator) -> np.ndarray:
    """% passing each of APERTURES_MM, with a lab's scatter."""
    exact = 100.0 * logn(APERTURES_MM, MASS_MEDIAN_MM, SIGMA_LN)
    measured = exact + rng.normal(0.0, [repeatability(q) for q in exact])
    return np.round(np.clip(np.maximum.accumulate(measured), 0.0, 100.0), 1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=2021)
    parser.add_argument("--out", type=Path, default=Path("config/examples/sieve_gravel_8_16.csv"))
    args = parser.parse_args()
    passing = sieve_sheet(np.random.default_rng(args.seed))
    lines = [
        "# Sieve analysis of a gravel 8/16-like material: Richter & Will's (2021) LOGN fit",
        f"# (d50 {MASS_MEDIAN_MM} mm, sigma_ln {SIGMA_LN}) with ASTM C136's repeatability as "
        "scatter. Written by",
        f"# python benchmarks/sieve_gravel_8_16.py --seed {args.seed}",
        "d_mm,Q3_percent",
    ]
    lines += [f"{d:g},{q:.1f}" for d, q in zip(APERTURES_MM, passing)]
    args.out.write_text("\n".join(lines) + "\n", encoding="utf-8")
    print(f"{args.out}: {len(APERTURES_MM)} sieves, seed {args.seed}")


if __name__ == "__main__":
    main()
