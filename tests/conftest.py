"""Shared test helpers: tiny studies on the analytic engine and synthetic heaps."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

ANALYTIC_STUDY = {
    "study": "unit",
    "engine": {"name": "analytic", "noise": 0.0},
    "parameters": {"sliding_friction_pp": {"lower": 0.1, "upper": 0.9},
                   "rolling_friction_pp": {"lower": 0.02, "upper": 0.3}},
    "fixed": {"restitution": 0.5},
    "targets": [
        {"scene": "cylinder_lift", "response": "angle_of_repose", "value": 25.0},
        {"scene": "cylinder_lift", "response": "bulk_density", "value": 1450.0},
    ],
    "replicates": 2,
    "seed": 3,
}


@pytest.fixture
def analytic_config():
    """A fresh copy of a valid analytic-engine study config."""
    return copy.deepcopy(ANALYTIC_STUDY)


def cone_of_spheres(angle_deg: float, base_radius: float, d: float,
                    plateau_radius: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Spheres of diameter d stacked in columns so the surface is a cone (or a mesa).

    Surface height at distance rho: (base_radius - max(rho, plateau_radius)) tan(angle);
    each column holds spheres up to that height.
    """
    slope = math.tan(math.radians(angle_deg))
    positions = []
    n = int(base_radius / d) + 1
    for i in range(-n, n + 1):
        for j in range(-n, n + 1):
            x, y = (i + 0.5) * d, (j + 0.5) * d
            rho = math.hypot(x, y)
            height = (base_radius - max(rho, plateau_radius)) * slope
            layers = max(1, int(round(height / d)))
            if rho > base_radius:
                continue
            positions += [(x, y, d / 2 + k * d) for k in range(layers)]
    x = np.array(positions)
    return x, np.full(len(x), d / 2)
