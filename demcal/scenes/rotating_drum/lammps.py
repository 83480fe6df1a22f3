"""Rotating drum on LAMMPS (GRANULAR package): fill, settle, spin up, watch the surface.

Runs inside the LAMMPS engine's child process. The drum is a cylinder region
along y, turned by the region's ``rotate`` keyword, so that its granular wall
drags the material at the mantle's speed; y is periodic (no end walls). The
spheres are placed at random inside the drum (random sequential addition: a
drum filled to 60 % is too dense for ``create_atoms random``) and settle; the
drum then turns, and after ``spinup_revolutions`` the positions are saved in
``snapshots`` evenly over ``window_revolutions``, each giving the running
estimates of the responses.
"""

from __future__ import annotations

import math

import numpy as np

from demcal.engines.base import RunMonitor, RunResult, SimulationJob
from demcal.engines.lammps_driver import LammpsDriver, num
from demcal.engines.particles import random_loose_packing
from demcal.errors import SimulationFailed
from demcal.physics.contact import GRAVITY
from demcal.scenes.rotating_drum import drum_particle_count, surface
from demcal.scenes.rotating_drum.regime import angular_speed

CONTAINER = "the drum"
#: Share of the progress bar the fill takes before the drum turns.
FILL_SHARE = 0.2


class RotatingDrum(LammpsDriver):
    """One LAMMPS simulation of the test; ``run`` drives the stages."""

    def __init__(self, job: SimulationJob, monitor: RunMonitor):
        super().__init__(job, monitor, count=drum_particle_count(job.settings))
        self.radius, self.depth = self.s["drum_diameter"] / 2.0, self.s["depth"]
        self.potential_height = 2.0 * self.radius
        #: simulated time [s] the drum started turning at, and how long it turns
        self.turning_since, self.turning_time = 0.0, 0.0

    def build(self) -> None:
        radius, edge = self.radius, self.radius + self.d_max
        self.create_domain((-edge, 0.0, -edge), (edge, self.depth, edge), "f p f")

        def inside(centre: np.ndarray, sphere_radius: float) -> bool:
            return bool(math.hypot(centre[0], centre[2]) <= radius - sphere_radius)

        centres = random_loose_packing(
            self.diameters,
            (-radius, 0.0, -radius),
            (radius, self.depth, radius),
            self.rng,
            "the drum; lower fill_level",
            inside=inside,
            periodic=(False, True, False),
        )
        self.place_spheres(centres)
        self.lmp.commands_list(
            [
                "variable turned equal 0.0",
                f"region drum cylinder y 0 0 {num(radius)} INF INF side in "
                f"rotate v_turned 0 0 0 0 1 0 units box",
                f"fix drum all wall/gran/region granular {self.wall_model()} region drum",
            ]
        )
        self.start_dynamics()

    def stages(self, measurements: dict[str, float], arrays: dict[str, np.ndarray]) -> None:
        fall_time = math.sqrt(2.0 * self.s["drum_diameter"] / GRAVITY)
        measurements["fill_at_rest"] = float(
            self.settle("fill", 0.0, FILL_SHARE, False, min_time=fall_time, container=CONTAINER)
        )
        omega = angular_speed(self.s)
        self.turning_since = self.lmp.get_thermo("time")
        self.lmp.command(f"variable turned equal {num(omega)}*(time-{num(self.turning_since)})")
        period = 2.0 * math.pi / omega
        spinup = self.s["spinup_revolutions"] * period
        self.turning_time = spinup + self.s["window_revolutions"] * period
        snapshots = self.s["snapshots"]
        times = spinup + (self.turning_time - spinup) * np.arange(1, snapshots + 1) / snapshots
        xz: list[np.ndarray] = []
        radii: list[np.ndarray] = []
        for taken, until in enumerate(times, start=1):
            self.turn(self.turning_since + until)
            x, r, _ = self.particles()
            xz.append(x[:, [0, 2]])
            radii.append(r)
            arrays.update(
                surface_xz=np.array(xz), surface_r=np.array(radii), surface_time=times[:taken]
            )
            self.estimate(arrays, taken == snapshots)

    def turn(self, until: float) -> None:
        """Run, the drum turning, until simulated time ``until`` [s]."""
        steps = max(1, math.ceil((until - self.lmp.get_thermo("time")) / self.dt))
        done = 0
        while done < steps:
            self.check_stop()
            step = min(self.chunk, steps - done)
            self.advance(step, "turning", allow_loss=False, container=CONTAINER)
            done += step
            turned = (self.lmp.get_thermo("time") - self.turning_since) / self.turning_time
            self.monitor.progress(FILL_SHARE + (1.0 - FILL_SHARE) * min(1.0, turned), "turning")

    def estimate(self, arrays: dict[str, np.ndarray], final: bool) -> None:
        """The responses from the snapshots so far: early estimates, the last final. The
        fluctuation needs two snapshots."""
        try:
            angle, fluctuation = surface(arrays, self.s)
        except SimulationFailed:
            if final:
                raise
            return
        estimates = {"dynamic_angle_of_repose": angle}
        if len(arrays["surface_xz"]) > 1:
            estimates["interface_fluctuation"] = fluctuation
        self.monitor.progress(
            FILL_SHARE + (1.0 - FILL_SHARE) * len(arrays["surface_xz"]) / self.s["snapshots"],
            "window",
            estimates,
            final=final,
        )


def run(job: SimulationJob, monitor: RunMonitor) -> RunResult:
    """The scene's LAMMPS driver: run one simulation (in the LAMMPS engine's child process)."""
    return RotatingDrum(job, monitor).run()
