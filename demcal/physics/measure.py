"""Bulk measurements from particle positions: surface profile, bulk density, slope angles.

All lengths in m, angles returned in degrees. Particles are given as centre
positions ``x`` (N x 3, floor at z = 0) and radii ``r`` (N).
"""

from __future__ import annotations

import math

import numpy as np

from demcal.errors import SimulationFailed


def surface_columns(
    x: np.ndarray, r: np.ndarray, cell: float, centre: tuple[float, float] = (0.0, 0.0)
) -> tuple[np.ndarray, np.ndarray]:
    """Free-surface height on a grid of square columns of side ``cell``.

    For every occupied column, the top is max(z + r) of the spheres whose
    centres fall in it (the highest point of material). Returns the radial
    distance of each column centre from ``centre`` and its top height.
    """
    centres, top = column_tops(x - np.array([*centre, 0.0]), r, cell)
    return np.hypot(centres[:, 0], centres[:, 1]), top


def column_tops(x: np.ndarray, r: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """Highest point max(z + r) of the spheres in each occupied column of a square grid.

    The grid has side ``cell`` and a corner at x = y = 0. Returns the column
    centres (K x 2) and their top heights (K).
    """
    ij = np.floor(x[:, :2] / cell).astype(np.int64)
    keys, inverse = np.unique(ij, axis=0, return_inverse=True)
    top = np.full(len(keys), -np.inf)
    np.maximum.at(top, inverse.ravel(), x[:, 2] + r)
    return (keys + 0.5) * cell, top


def fill_bulk_density(
    x: np.ndarray, r: np.ndarray, mass: np.ndarray, cylinder_radius: float, cell: float
) -> tuple[float, float]:
    """Bulk density [kg/m^3] of a settled fill in a cylinder, and the fill height [m].

    Fill height H = mean free-surface height (top of the highest sphere per
    column, so whole spheres lie below it) over the columns farther than two
    cells from the wall; bulk density = total mass / (pi R^2 H).
    """
    radius, top = surface_columns(x, r, cell)
    inner = radius < cylinder_radius - 2.0 * cell
    if not inner.any():
        raise SimulationFailed(
            "fill has no surface columns away from the wall: "
            "cylinder too narrow for the particle size"
        )
    height = float(np.mean(top[inner]))
    return float(np.sum(mass) / (math.pi * cylinder_radius**2 * height)), height


def radial_profile(x: np.ndarray, r: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """Heap surface height against distance from the heap's axis.

    The surface columns (``surface_columns``, centred on the centroid of the
    particles) are grouped in rings of width ``cell``; each ring's height is
    its highest column, which is robust to columns whose top sphere happens
    to sit in a neighbouring cell. Returns ring mid-radii and heights.
    """
    centre = (float(np.mean(x[:, 0])), float(np.mean(x[:, 1])))
    radius, top = surface_columns(x, r, cell, centre)
    ring = np.floor(radius / cell).astype(np.int64)
    height = np.full(ring.max() + 1, -np.inf)
    np.maximum.at(height, ring, top)
    occupied = np.isfinite(height)
    return ((np.arange(len(height)) + 0.5) * cell)[occupied], height[occupied]


def heap_angle_flank_fit(
    x: np.ndarray, r: np.ndarray, cell: float, band: tuple[float, float] = (0.2, 0.8)
) -> float:
    """Angle of repose [deg] from a straight-line fit of the heap flank.

    The radial profile (``radial_profile``) is fitted with a line
    h = a - tan(alpha) rho over the rings whose height lies between
    ``band[0]`` and ``band[1]`` of the heap height: the band leaves out the
    rounded crest and the toe. With fewer than three rings in the band (a
    heap one or two layers high) the whole profile is fitted. A rising
    profile (material piled at the rim) counts as 0 deg.
    """
    radius, height = radial_profile(x, r, cell)
    if len(height) < 3:
        raise SimulationFailed(f"heap profile has only {len(height)} rings: no heap to measure")
    top = height.max()
    in_band = (height >= band[0] * top) & (height <= band[1] * top)
    if in_band.sum() < 3:
        in_band = np.ones_like(height, dtype=bool)
    slope = np.polyfit(radius[in_band], height[in_band], 1)[0]
    return max(0.0, math.degrees(math.atan(-slope)))


def heap_angle_height_radius(
    x: np.ndarray, r: np.ndarray, cell: float, bottom_layer: float
) -> float:
    """Angle of repose [deg] = arctan(h / r_t), after Rackl & Hanley (2017), Appendix A.

    h is the heap height minus the bottom layer hidden by the rim
    (``bottom_layer``, one particle diameter); r_t is the radius of the
    projected heap area, taken twice as the radius of the circle of equal
    area around the centroid of the occupied columns and dropping the columns
    outside it (the loosely covered edge).
    """
    xy, z_top = x[:, :2], x[:, 2] + r
    if len(xy) == 0:
        raise SimulationFailed("no particles on the plate: no heap to measure")
    cells = np.unique(np.floor(xy / cell).astype(np.int64), axis=0)
    centres = (cells + 0.5) * cell
    keep = np.ones(len(centres), dtype=bool)
    for _ in range(2):
        centroid = centres[keep].mean(axis=0)
        radius = math.sqrt(keep.sum() * cell * cell / math.pi)
        keep &= np.hypot(*(centres - centroid).T) <= radius
    height = float(z_top.max()) - bottom_layer
    return math.degrees(math.atan2(max(height, 0.0), radius))


def surface_profile_along_x(
    x: np.ndarray, r: np.ndarray, cell: float, x_range: tuple[float, float]
) -> tuple[np.ndarray, np.ndarray]:
    """Free-surface height of a quasi-2-D pile against x: max(z + r) per x-bin of width ``cell``.

    Only spheres with centres in ``x_range`` count; empty bins are left out.
    Returns the bin centres and heights.
    """
    inside = (x[:, 0] >= x_range[0]) & (x[:, 0] < x_range[1])
    bins = np.floor((x[inside, 0] - x_range[0]) / cell).astype(np.int64)
    if len(bins) == 0:
        return np.empty(0), np.empty(0)
    top = np.full(bins.max() + 1, -np.inf)
    np.maximum.at(top, bins, x[inside, 2] + r[inside])
    occupied = np.isfinite(top)
    return (x_range[0] + (np.arange(len(top)) + 0.5) * cell)[occupied], top[occupied]


def falling_sigmoid(
    position: np.ndarray, low: float, high: float, centre: float, width: float
) -> np.ndarray:
    """low + (high - low) / (1 + exp((position - centre) / width)): a step falling with position."""
    return low + (high - low) / (1.0 + np.exp(np.clip((position - centre) / width, -50.0, 50.0)))


def heap_angle_sigmoid_fit(position: np.ndarray, height: np.ndarray) -> float:
    """Angle of repose [deg] at the inflexion point of a sigmoid fitted to a pile profile.

    Samuelsson (2023), sec. 4.1: the profile h(x) of a pile that falls away
    with x is fitted with ``falling_sigmoid``; its steepest slope, at the
    inflexion point, is (high - low) / (4 width), and the angle is its arctangent.
    """
    from scipy.optimize import curve_fit

    if len(height) < 5:
        raise SimulationFailed(f"pile profile has only {len(height)} columns: no pile to measure")
    span = float(position.max() - position.min())
    guess = (float(height.min()), float(height.max()), float(np.median(position)), 0.1 * span)
    bounds = (
        [-np.inf, -np.inf, position.min(), 1e-6 * span],
        [np.inf, np.inf, position.max(), 10.0 * span],
    )
    try:
        (low, high, _centre, width), _ = curve_fit(
            falling_sigmoid, position, height, p0=guess, bounds=bounds, maxfev=5000
        )
    except RuntimeError as exc:
        raise SimulationFailed(f"sigmoid fit of the pile profile failed: {exc}") from None
    return max(0.0, math.degrees(math.atan((high - low) / (4.0 * width))))


def discharge_rate(
    times: np.ndarray,
    held_mass: np.ndarray,
    total_mass: float,
    band: tuple[float, float],
    time_allowed: float,
) -> float:
    """Mass flow [kg/s] out of a container: slope of its held mass against time.

    Samuelsson (2023), sec. 4.1 fits a line to the mass above the hopper
    outlet sampled over time; here only the samples whose discharged fraction
    1 - m/m_total lies in ``band`` count, which leaves out the start-up and
    the emptying of the last layers. With fewer than three samples in the
    band: if the discharge went past the band (sampled too coarsely), the
    mean rate over the record; if it stalled before the band's end (a
    clogged outlet), the mass discharged over ``time_allowed`` [s], so that
    an outlet that clogs sooner reads a lower rate.
    """
    discharged = 1.0 - held_mass / total_mass
    in_band = (discharged >= band[0]) & (discharged <= band[1])
    if in_band.sum() >= 3:
        return float(-np.polyfit(times[in_band], held_mass[in_band], 1)[0])
    discharged_mass = float(held_mass[0] - held_mass[-1])
    if discharged[-1] >= band[1]:
        elapsed = float(times[-1] - times[0])
        return discharged_mass / elapsed if elapsed > 0.0 else 0.0
    return discharged_mass / time_allowed


def slide_time_with_penalty(
    times: np.ndarray,
    remaining_mass: np.ndarray,
    total_mass: float,
    empty_fraction: float,
    end_time: float,
) -> float:
    """Time [s] until the material has left the slide, penalised if it never does.

    Samuelsson (2023), sec. 4.1: the first time the mass still on the way
    (here: in the hopper or on the slide) is below ``empty_fraction`` of the
    total; if it never is, ``end_time`` (the simulation's time limit) plus
    10 times the fraction remaining, so that very high friction still gives a
    graded response.
    """
    below = np.flatnonzero(remaining_mass < empty_fraction * total_mass)
    if len(below):
        return float(times[below[0]])
    return float(end_time + 10.0 * remaining_mass[-1] / total_mass)


def box_bulk_density(x: np.ndarray, mass: np.ndarray, box: tuple[float, float, float]) -> float:
    """Bulk density [kg/m^3] of a filled box: mass of the spheres whose centres lie inside / volume.

    ``box`` = (length, width, height) [m] of a box with a corner at the origin
    (Richter & Will 2021: mass in the box over the box volume). Counting by
    centre, a sphere cut by the top face counts whole.
    """
    length, width, height = box
    inside = (
        (x[:, 0] >= 0.0)
        & (x[:, 0] <= length)
        & (x[:, 1] >= 0.0)
        & (x[:, 1] <= width)
        & (x[:, 2] >= 0.0)
        & (x[:, 2] <= height)
    )
    return float(np.sum(mass[inside]) / (length * width * height))


def box_slope_angle(
    x: np.ndarray, r: np.ndarray, cell: float, length: float, band: tuple[float, float] = (0.2, 0.8)
) -> float:
    """Shear angle [deg]: slope of the material left in a box open at x = ``length``.

    The surface (``column_tops`` on a grid of side ``cell``) of the spheres
    whose centres lie in 0 <= x <= length is fitted with a line
    z = a - tan(phi) x over the columns whose top lies between ``band[0]`` and
    ``band[1]`` of the highest top, leaving out the struck-off plateau at the
    back wall and the toe at the opening (Richter & Will 2021 fit a line
    through the uppermost particles). With fewer than three distinct column
    positions along x in the band, all columns are fitted. A surface rising
    towards the opening counts as 0 deg.
    """
    kept = (x[:, 0] >= 0.0) & (x[:, 0] <= length)
    if not kept.any():
        raise SimulationFailed("no particles left in the box: no slope to measure")
    centres, top = column_tops(x[kept], r[kept], cell)
    highest = top.max()
    in_band = (top >= band[0] * highest) & (top <= band[1] * highest)
    if len(np.unique(centres[in_band, 0])) < 3:
        in_band = np.ones_like(top, dtype=bool)
    if len(np.unique(centres[in_band, 0])) < 2:
        raise SimulationFailed("slope covers a single column along the box: no slope to measure")
    slope = np.polyfit(centres[in_band, 0], top[in_band], 1)[0]
    return max(0.0, math.degrees(math.atan(-slope)))


#: Fewest surface columns a drum's interface line is fitted to.
MIN_INTERFACE_COLUMNS = 3


def drum_surface_heights(
    xz: np.ndarray, r: np.ndarray, radius: float, cell: float
) -> tuple[np.ndarray, np.ndarray]:
    """Free-surface height of the material in a rotating drum, per snapshot, on one grid.

    ``xz`` (S x N x 2) holds the sphere centres of S snapshots across the
    drum's axis (horizontal, vertical; axis at 0, 0) and ``r`` (S x N) their
    radii. The drum's width -radius..radius is cut into columns of width
    ``cell``; a column's height is max(z + r) of the spheres whose centres
    fall in it, seen through the whole depth as a camera at the end wall sees
    it, NaN where it is empty. Returns the column centres (B) and heights (S x B).
    """
    count = max(1, math.ceil(2.0 * radius / cell))
    centres = -radius + (np.arange(count) + 0.5) * cell
    heights = np.full((len(xz), count), np.nan)
    for snapshot, (positions, radii) in enumerate(zip(xz, r, strict=True)):
        column = np.clip(np.floor((positions[:, 0] + radius) / cell), 0, count - 1).astype(int)
        np.fmax.at(heights[snapshot], column, positions[:, 1] + radii)
    return centres, heights


def drum_interface(centres: np.ndarray, heights: np.ndarray, band: float) -> tuple[float, float]:
    """Dynamic angle of repose [deg] and interface fluctuation [m] of a rotating drum.

    The columns occupied in every snapshot span the free surface from wall to
    wall; its central ``band`` share (leaving out where the surface bends into
    the wall) is taken. The angle is that of a straight line fitted to the
    time-averaged surface there, as drum instruments average the interface
    over their images; the fluctuation is the rms deviation of the single
    snapshots' surface from that average, the quantity drum instruments turn
    into a cohesive index.
    """
    occupied = np.isfinite(heights).all(axis=0)
    if not occupied.any():
        raise SimulationFailed("the drum holds no material in some snapshot: no surface to fit")
    lowest, highest = centres[occupied].min(), centres[occupied].max()
    middle, half_width = 0.5 * (lowest + highest), 0.5 * band * (highest - lowest)
    kept = occupied & (np.abs(centres - middle) <= half_width)
    if kept.sum() < MIN_INTERFACE_COLUMNS:
        raise SimulationFailed(
            f"the drum's free surface spans only {int(kept.sum())} columns in its central band: "
            f"too few to fit a line; use a larger drum or smaller particles"
        )
    surface = heights[:, kept]
    average = surface.mean(axis=0)
    slope = np.polyfit(centres[kept], average, 1)[0]
    fluctuation = math.sqrt(float(np.mean((surface - average) ** 2)))
    return math.degrees(math.atan(abs(slope))), fluctuation


def tangent_modulus(
    strain: np.ndarray, stress: np.ndarray, stress_band: tuple[float, float]
) -> float:
    """Slope [Pa] of stress against strain, fitted by least squares over the samples whose
    stress lies in ``stress_band`` (Pa); the modulus of one branch (loading or unloading) of
    a confined compression test. Fails with fewer than three samples in the band."""
    inside = (stress >= stress_band[0]) & (stress <= stress_band[1])
    if inside.sum() < 3 or np.ptp(strain[inside]) == 0.0:
        raise SimulationFailed(
            f"only {int(inside.sum())} samples of the stress-strain curve lie between "
            f"{stress_band[0]:.3g} and {stress_band[1]:.3g} Pa: too few for a modulus; slow the "
            f"piston (piston_speed)"
        )
    return float(abs(np.polyfit(strain[inside], stress[inside], 1)[0]))


def height_at_stress(gap: np.ndarray, stress: np.ndarray, level: float) -> float:
    """The piston's height [m] where a loading curve's stress first reaches ``level`` [Pa],
    interpolated linearly between the samples around it (``gap`` and ``stress`` in the order
    sampled). Fails if the stress never gets there."""
    reached = np.flatnonzero(stress >= level)
    if len(reached) == 0:
        raise SimulationFailed(f"the stress never reached {level:.3g} Pa: no height to read")
    i = int(reached[0])
    if i == 0:
        return float(gap[0])
    share = (level - stress[i - 1]) / (stress[i] - stress[i - 1])
    return float(gap[i - 1] + share * (gap[i] - gap[i - 1]))
