"""Bulk measurements on synthetic packings with known answers."""

import math

import numpy as np
import pytest
from helpers import cone_of_spheres

from demcal.errors import SimulationFailed
from demcal.physics import measure

D = 2.0e-3


@pytest.mark.parametrize("angle", [15.0, 25.0, 35.0])
def test_flank_fit_recovers_cone_angle(angle):
    x, r = cone_of_spheres(angle, base_radius=40 * D, d=D)
    assert measure.heap_angle_flank_fit(x, r, D) == pytest.approx(angle, abs=1.5)


def test_height_radius_agrees_on_a_cone_but_not_on_a_mesa():
    """arctan(h/r) (Rackl & Hanley, App. A) equals the flank angle only for a full cone.

    On a heap with a flat top (material that did not flow), the flank fit
    still finds the flank's 30 deg; arctan(height / radius) reports the
    average slope from the crest to the toe, which is smaller.
    """
    cone_x, cone_r = cone_of_spheres(30.0, base_radius=40 * D, d=D)
    mesa_x, mesa_r = cone_of_spheres(30.0, base_radius=40 * D, d=D, plateau_radius=20 * D)
    cone_flank = measure.heap_angle_flank_fit(cone_x, cone_r, D)
    cone_ratio = measure.heap_angle_height_radius(cone_x, cone_r, D, bottom_layer=D)
    mesa_flank = measure.heap_angle_flank_fit(mesa_x, mesa_r, D)
    mesa_ratio = measure.heap_angle_height_radius(mesa_x, mesa_r, D, bottom_layer=D)
    assert cone_flank == pytest.approx(30.0, abs=1.5)
    assert cone_ratio == pytest.approx(30.0, abs=3.0)
    assert mesa_flank == pytest.approx(30.0, abs=2.0)
    # the mesa's crest-to-toe slope: 20 D of height over a 40 D radius
    assert mesa_ratio == pytest.approx(
        math.degrees(math.atan(0.5 * math.tan(math.radians(30)))), abs=3.0
    )
    assert mesa_ratio < mesa_flank - 8.0


def test_flat_layer_has_zero_angle():
    x, r = cone_of_spheres(0.0, base_radius=20 * D, d=D)
    assert measure.heap_angle_flank_fit(x, r, D) == pytest.approx(0.0, abs=0.5)


def test_too_few_particles_is_a_recorded_failure():
    with pytest.raises(SimulationFailed, match="no heap"):
        measure.heap_angle_flank_fit(np.array([[0.0, 0.0, D / 2]]), np.array([D / 2]), D)


def test_bulk_density_of_a_simple_cubic_fill():
    """Fill height is the mean top of the columns; density is mass / (pi R^2 H)."""
    radius, layers = 20 * D, 10
    grid = np.arange(-radius, radius, D) + D / 2
    pts = [
        (gx, gy, D / 2 + k * D)
        for gx in grid
        for gy in grid
        if math.hypot(gx, gy) < radius - D / 2
        for k in range(layers)
    ]
    x = np.array(pts)
    r = np.full(len(x), D / 2)
    mass = np.full(len(x), 2500.0 * math.pi / 6 * D**3)
    density, height = measure.fill_bulk_density(x, r, mass, radius, D)
    assert height == pytest.approx(layers * D)
    assert density == pytest.approx(mass.sum() / (math.pi * radius**2 * layers * D))
    # the lattice's pi/6, less the columns cut by the round wall
    assert 0.9 * 2500.0 * math.pi / 6 < density < 2500.0 * math.pi / 6
