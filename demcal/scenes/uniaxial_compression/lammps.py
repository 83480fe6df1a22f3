"""Confined uniaxial compression on LAMMPS (GRANULAR package): fill, settle, load, unload.

Runs inside the LAMMPS engine's child process. Geometry from regions: a floor
plane, the cylinder's wall (open at the top) and the piston, a plane region
that the variable ``pz`` moves at constant speed; its wall reports the force
on every sphere it touches (``contacts``), whose sum over the cross-section
is the stress. The spheres are placed at random in a column of the cylinder
and settle; the piston starts just above the highest sphere, comes down at
``piston_speed`` until the stress reaches ``max_stress`` and goes back up
until it has fallen to the seating stress, the stress and the piston's height
sampled every ``SAMPLE_SHARE`` of the fill height of travel.
"""

from __future__ import annotations

import math

import numpy as np

from demcal.engines.base import RunMonitor, RunResult, SimulationJob
from demcal.engines.lammps_driver import LammpsDriver, num
from demcal.engines.particles import INSERTION_SOLID_FRACTION, random_loose_packing
from demcal.errors import SimulationFailed
from demcal.physics.contact import GRAVITY
from demcal.scenes.uniaxial_compression import (
    cross_section,
    density_at,
    fill_particle_count,
    modulus,
)

CONTAINER = "the cylinder"
#: Piston travel between two samples of the stress, a share of the fill height (a stiff
#: material's unloading band spans about a thousandth of it).
SAMPLE_SHARE = 1.0e-4
#: Shares of the progress bar at the end of the fill and of the loading.
FILL_SHARE, LOADED_SHARE = 0.5, 0.8
#: Samples of the stress between two progress reports.
PROGRESS_SAMPLES = 100


class UniaxialCompression(LammpsDriver):
    """One LAMMPS simulation of the test; ``run`` drives the stages."""

    def __init__(self, job: SimulationJob, monitor: RunMonitor):
        super().__init__(job, monitor, count=fill_particle_count(job.settings))
        self.radius = self.s["cylinder_diameter"] / 2.0
        self.column_top = self.d_max + self.particle_volume / (
            INSERTION_SOLID_FRACTION * math.pi * (self.radius - 0.5 * self.d_max) ** 2
        )
        self.potential_height = self.column_top
        self.area = cross_section(self.s)

    def build(self) -> None:
        radius, d, top = self.radius, self.d_max, self.column_top + 2.0 * self.d_max
        pw = self.wall_model()
        edge = radius + d
        self.create_domain((-edge, -edge, -0.5 * d), (edge, edge, top + d), "f f f")

        def inside(centre: np.ndarray, sphere_radius: float) -> bool:
            return bool(math.hypot(centre[0], centre[1]) <= radius - sphere_radius)

        centres = random_loose_packing(
            self.diameters,
            (-radius, -radius, 0.0),
            (radius, radius, self.column_top),
            self.rng,
            "the column above the cylinder's floor",
            inside=inside,
        )
        self.place_spheres(centres)
        self.lmp.commands_list(
            [
                f"variable pz equal {num(top)}",
                f"fix floor all wall/gran granular {pw} zplane 0.0 NULL",
                f"region tube cylinder z 0 0 {num(radius)} 0 {num(top)} side in open 1 open 2 "
                f"units box",
                f"fix tube all wall/gran/region granular {pw} region tube",
                "region piston plane 0 0 0 0 0 -1 side in move NULL NULL v_pz units box",
                f"fix piston all wall/gran/region granular {pw} region piston contacts",
            ]
        )
        self.start_dynamics()

    def stress(self) -> float:
        """The stress [Pa] the spheres exert on the piston now."""
        from lammps import LMP_STYLE_ATOM, LMP_TYPE_ARRAY

        n = self.lmp.extract_global("nlocal")
        contacts = self.lmp.numpy.extract_fix("piston", LMP_STYLE_ATOM, LMP_TYPE_ARRAY)
        return float(-np.sum(contacts[:n, 3])) / self.area

    def stages(self, measurements: dict[str, float], arrays: dict[str, np.ndarray]) -> None:
        fall_time = math.sqrt(2.0 * self.column_top / GRAVITY)
        measurements["fill_at_rest"] = float(
            self.settle("fill", 0.0, FILL_SHARE, False, min_time=fall_time, container=CONTAINER)
        )
        x, r, m = self.particles()
        arrays["mass"] = m
        self.compress(float(np.max(x[:, 2] + r)), arrays)

    def compress(self, top: float, arrays: dict[str, np.ndarray]) -> None:
        """Load from just above the fill's ``top`` [m] to ``max_stress`` and unload to the
        seating stress, sampling the piston's height and the stress every SAMPLE_SHARE of the
        fill height of travel."""
        speed = self.s["piston_speed"]
        steps = max(1, round(SAMPLE_SHARE * self.s["fill_height"] / speed / self.dt))
        start = top + 0.05 * self.d_max
        samples: list[tuple[float, float, bool]] = []
        for loading in (True, False):
            since = self.lmp.get_thermo("time")
            sign = "-" if loading else "+"
            self.lmp.command(
                f"variable pz equal {num(start)}{sign}{num(speed)}*(time-{num(since)})"
            )
            end = self.s["max_stress"] if loading else self.s["seating_stress"]
            stage = "loading" if loading else "unloading"
            while True:
                self.check_stop()
                self.advance(steps, stage, False, CONTAINER)
                gap, stress = float(self.lmp.extract_variable("pz")), self.stress()
                samples.append((gap, stress, loading))
                if stress >= end if loading else stress <= end:
                    break
                if len(samples) % PROGRESS_SAMPLES == 0:
                    self.monitor.progress(self.progress_at(stress, loading), stage)
                if not 0.0 < gap <= top + self.d_max:
                    raise SimulationFailed(
                        f"the piston {'reached the floor' if loading else 'left the material'} "
                        f"before the stress {'reached' if loading else 'fell to'} {end:g} Pa"
                    )
            start = gap
            gaps, stresses, branch = (np.array(v) for v in zip(*samples, strict=True))
            arrays.update(gap=gaps, stress=stresses, loading=branch.astype(float))
            self.report(arrays, loading)

    def progress_at(self, stress: float, loading: bool) -> float:
        """The progress bar's share at ``stress`` [Pa]: loading fills it to LOADED_SHARE,
        unloading the rest."""
        top, seat = float(self.s["max_stress"]), float(self.s["seating_stress"])
        if loading:
            return FILL_SHARE + (LOADED_SHARE - FILL_SHARE) * min(max(stress / top, 0.0), 1.0)
        return LOADED_SHARE + (1.0 - LOADED_SHARE) * min(
            max((top - stress) / (top - seat), 0.0), 1.0
        )

    def report(self, arrays: dict[str, np.ndarray], loading: bool) -> None:
        """The responses a branch of the curve gives, final as it ends."""
        if loading:
            estimates = {
                "seated_bulk_density": density_at(arrays, self.s, self.s["seating_stress"]),
                "compressed_bulk_density": density_at(arrays, self.s, self.s["max_stress"]),
                "loading_modulus": modulus(arrays, self.s, loading=True),
            }
        else:
            estimates = {"unloading_modulus": modulus(arrays, self.s, loading=False)}
        stage = "loading" if loading else "unloading"
        self.monitor.progress(LOADED_SHARE if loading else 1.0, stage, estimates, final=True)


def run(job: SimulationJob, monitor: RunMonitor) -> RunResult:
    """The scene's LAMMPS driver: run one simulation (in the LAMMPS engine's child process)."""
    return UniaxialCompression(job, monitor).run()
