"""The particles and time step of one simulation, whatever the engine runs it.

Shared by the scene drivers of every engine so that one seed gives the same
spheres and the same time step on LAMMPS and on LIGGGHTS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from demcal.engines.base import SimulationJob
from demcal.physics.psd import diameter_range, sample_diameters
from demcal.physics.timestep import rayleigh_time

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
    smallest possible sphere (Rackl & Hanley 2017, eq. 1).
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
