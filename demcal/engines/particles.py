"""The particles and time step of one simulation, whatever the engine runs it.

Shared by the scene drivers of every engine so that one seed gives the same
spheres and the same time step on LAMMPS and on LIGGGHTS.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from demcal.engines.base import SimulationJob
from demcal.errors import SimulationFailed
from demcal.physics.psd import diameter_range, sample_diameters
from demcal.physics.timestep import (
    ADHESION_PARAMETERS,
    JKR_STEPS_PER_CONTACT,
    jkr_contact_time,
    rayleigh_time,
)

#: Random insertion fills at most this solid fraction of the insertion zone.
INSERTION_SOLID_FRACTION = 0.25
#: Kinetic energy above this multiple of the material's potential energy is a blow-up.
BLOWUP_FACTOR = 10.0
#: Simulated time between checks of STOP, stability and rest [s].
CHUNK_TIME = 0.02


@dataclass(frozen=True)
class SimulationParticles:
    """Sphere diameters [m], the largest possible [m], Rayleigh time and time step [s],
    total sphere volume [m^3] and mass [kg], and the steps per check (``CHUNK_TIME``)."""

    diameters: np.ndarray
    d_max: float
    rayleigh_time: float
    timestep: float
    volume: float
    mass: float
    chunk_steps: int


def simulation_particles(
    job: SimulationJob, rng: np.random.Generator, count: int | None = None
) -> SimulationParticles:
    """Sample ``count`` (default: the ``particle_count`` setting) spheres from the scene's PSD.

    The time step is ``job.timestep_fraction`` of the Rayleigh time of the
    smallest possible sphere (Rackl & Hanley 2017, eq. 1), and with adhesion
    at most a JKR_STEPS_PER_CONTACT-th of its adhesive contact's duration
    (`jkr_contact_time`, the larger surface energy of particles and walls).
    """
    s, p = job.settings, job.parameters
    diameters = sample_diameters(
        count if count is not None else s["particle_count"],
        s["d50"],
        s["sigma_ln"],
        s["psd_truncation"],
        rng,
    )
    d_min, d_max = diameter_range(s["d50"], s["sigma_ln"], s["psd_truncation"])
    rayleigh = rayleigh_time(
        d_min / 2.0, p["particle_density"], p["youngs_modulus"], p["poisson_ratio"]
    )
    dt = job.timestep_fraction * rayleigh
    surface_energy = max(p[name] for name in ADHESION_PARAMETERS)
    if surface_energy > 0.0:
        contact = jkr_contact_time(
            d_min / 2.0,
            p["particle_density"],
            p["youngs_modulus"],
            p["poisson_ratio"],
            surface_energy,
        )
        dt = min(dt, contact / JKR_STEPS_PER_CONTACT)
    volume = float(np.sum(math.pi / 6.0 * diameters**3))
    return SimulationParticles(
        diameters,
        d_max,
        rayleigh,
        dt,
        volume,
        p["particle_density"] * volume,
        max(50, round(CHUNK_TIME / dt)),
    )


def random_loose_packing(
    diameters: np.ndarray,
    lower: ArrayLike,
    upper: ArrayLike,
    rng: np.random.Generator,
    where: str,
    inside: Callable[[np.ndarray, float], bool] | None = None,
    periodic: tuple[bool, bool, bool] = (False, False, False),
    max_tries: int = 1000,
) -> np.ndarray:
    """Centres [m] of non-overlapping spheres placed at random, largest first, in a block.

    Random sequential addition: each sphere (diameters [m]) tries up to
    ``max_tries`` uniform positions that keep it wholly inside the block
    ``lower``..``upper`` [m] (and, given ``inside(centre, radius)``, inside
    that container too) and takes the first that overlaps no sphere placed
    before; a sphere that finds no place fails the run, naming ``where``.
    Unlike ``create_atoms random``, whose single overlap distance must be the
    largest diameter (so a wide PSD needs a column many times taller), the
    check uses each pair's sum of radii. Along a ``periodic`` axis a sphere may
    cross the block's faces and meets the spheres across them. Returns centres
    in the order of ``diameters``.
    """
    lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    wraps = np.asarray(periodic, dtype=bool)
    size = upper - lower
    # cells at least one largest diameter wide; along a periodic axis a whole number of them
    cells = np.maximum(1, np.floor(size / diameters.max())).astype(int)
    cell = np.where(wraps, size / cells, diameters.max())
    centres = np.full((len(diameters), 3), np.nan)
    grid: dict[tuple[int, ...], list[int]] = {}
    offsets = np.array([(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)])
    for index in np.argsort(-diameters, kind="stable"):
        radius = diameters[index] / 2.0
        margin = np.where(wraps, 0.0, radius)
        for _ in range(max_tries):
            centre = rng.uniform(lower + margin, upper - margin)
            if inside is not None and not inside(centre, radius):
                continue
            key = ((centre - lower) // cell).astype(int)
            neighbours = np.where(wraps, (key + offsets) % cells, key + offsets)
            near = sorted({j for o in map(tuple, neighbours) for j in grid.get(o, ())})
            apart = centres[near] - centre
            apart -= np.where(wraps, size * np.round(apart / size), 0.0)
            gaps = np.linalg.norm(apart, axis=1) - diameters[near] / 2.0
            if not near or gaps.min() >= radius:
                centres[index] = centre
                grid.setdefault(tuple(key), []).append(index)
                break
        else:
            placed = len(diameters) - int(np.isnan(centres[:, 0]).sum())
            raise SimulationFailed(
                f"could place only {placed} of {len(diameters)} particles in {where}"
            )
    return centres
