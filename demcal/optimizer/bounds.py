"""Box bounds of the calibrated parameters and the map to the unit box."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike


def to_unit_box(x: ArrayLike, lower: ArrayLike, upper: ArrayLike) -> np.ndarray:
    """Points in real units (rows, or one point) in the unit box of [lower, upper]:
    (x - lower) / (upper - lower), with no check that they lie inside."""
    low, high = np.asarray(lower, float), np.asarray(upper, float)
    unit: np.ndarray = (np.asarray(x, float) - low) / (high - low)
    return unit


def from_unit_box(u: ArrayLike, lower: ArrayLike, upper: ArrayLike) -> np.ndarray:
    """Points of the unit box (rows, or one point) in real units: lower + u (upper - lower)."""
    low, high = np.asarray(lower, float), np.asarray(upper, float)
    points: np.ndarray = low + np.asarray(u, float) * (high - low)
    return points


@dataclass(frozen=True)
class Bounds:
    """Lower and upper bound of each parameter, in the parameter's own (SI) units."""

    lower: tuple[float, ...]
    upper: tuple[float, ...]

    def __post_init__(self) -> None:
        if len(self.lower) != len(self.upper) or not self.lower:
            raise ValueError(
                f"bounds: lower has {len(self.lower)} values and upper {len(self.upper)}; "
                "they need the same, non-zero length"
            )
        for index, (low, high) in enumerate(zip(self.lower, self.upper)):
            if not (math.isfinite(low) and math.isfinite(high) and low < high):
                raise ValueError(
                    f"bounds[{index}]: need finite lower < upper, got {low!r}, {high!r}"
                )

    @classmethod
    def of(cls, lower: Iterable[float], upper: Iterable[float]) -> Bounds:
        return cls(tuple(float(v) for v in lower), tuple(float(v) for v in upper))

    @property
    def dimension(self) -> int:
        return len(self.lower)

    def to_unit(self, x: ArrayLike) -> np.ndarray:
        """Scale points (rows) to the unit box; raise ValueError if outside the bounds."""
        x = np.atleast_2d(np.asarray(x, float))
        if x.shape[1] != self.dimension:
            raise ValueError(f"point has {x.shape[1]} values, expected {self.dimension}")
        low, high = np.array(self.lower), np.array(self.upper)
        if np.any(x < low) or np.any(x > high) or not np.all(np.isfinite(x)):
            raise ValueError(
                f"point {x.tolist()} is outside the bounds {list(self.lower)} .. {list(self.upper)}"
            )
        return to_unit_box(x, low, high)

    def from_unit(self, u: ArrayLike) -> np.ndarray:
        """Map unit-box points (rows) back to real units."""
        return from_unit_box(np.atleast_2d(np.asarray(u, float)), self.lower, self.upper)


#: Share of a parameter's range within which a point counts as lying on that bound.
ON_BOUND_SHARE = 0.01


def on_bounds(unit_point: Iterable[float]) -> list[tuple[int, str]]:
    """(index, "lower"/"upper") of each coordinate of a unit-box point that lies on a bound.

    A best point on a bound often means the bounds cut the solution off.
    """
    return [
        (i, "lower" if u <= ON_BOUND_SHARE else "upper")
        for i, u in enumerate(unit_point)
        if u <= ON_BOUND_SHARE or u >= 1.0 - ON_BOUND_SHARE
    ]
