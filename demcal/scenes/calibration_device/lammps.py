"""Calibration device on LAMMPS: fill the hopper, open the trapdoor, discharge, slide, pile.

Runs inside the LAMMPS engine's child process. All parts are granular walls
on regions (``demcal.scenes.calibration_device.DeviceGeometry``): the floor
and the two end walls are planes, the slide and its support the solid
below the slide's plane right of its edge (an intersection of two
half-spaces), the hopper's vertical wall and the trapdoor blocks, its
sloping wall a prism. The box is periodic in depth. The trapdoor is a wall
fix that is removed to open the hopper.
"""

from __future__ import annotations

import math

import numpy as np

from demcal.engines.base import RunMonitor, RunResult, SimulationJob
from demcal.engines.lammps_driver import LammpsDriver, num, setup_commands
from demcal.engines.particles import INSERTION_SOLID_FRACTION
from demcal.physics import measure
from demcal.physics.contact import GRAVITY
from demcal.scenes.calibration_device import EARLY_ESTIMATE_AT, MASS_FLOW_BAND, device_geometry

CONTAINER = "the device"
#: Material counts as at rest after the opening only after this simulated time [s].
MIN_FLOW_TIME = 0.1


class CalibrationDevice(LammpsDriver):
    """One LAMMPS simulation of the device; ``run`` drives the stages."""

    def __init__(self, job: SimulationJob, monitor: RunMonitor):
        super().__init__(job, monitor)
        self.g = device_geometry(self.s, self.particle_volume, self.d_max, INSERTION_SOLID_FRACTION)
        self.potential_height = self.g.hopper_top

    def build(self) -> None:
        s, g, pw = self.s, self.g, self.wall_model()
        slide, beta = math.radians(s["slide_angle"]), math.radians(s["hopper_wall_angle"])
        depth, t, dm = s["depth"], g.wall_thickness, self.d_max
        outlet_right = g.outlet_left + s["orifice_width"]
        wall_height = g.hopper_top - g.hopper_bottom
        self.lmp.commands_list(
            [
                *setup_commands("f p f"),
                f"region box block 0 {num(g.box_right)} 0 {num(depth)} {num(-0.5 * dm)} "
                f"{num(g.hopper_top + 5.0 * dm)} units box",
                "create_box 1 box",
                "pair_style granular",
                f"pair_coeff * * {self.pair_model()}",
                f"neighbor {num(0.1 * dm)} bin",
                "neigh_modify delay 0 every 1 check yes",
                # insertion zone: inside the hopper, clear of its walls
                f"region insert_block block {num(g.outlet_left + 0.6 * dm)} {num(g.box_right)} "
                f"{num(0.5 * dm)} {num(depth - 0.5 * dm)} {num(g.hopper_bottom + 0.6 * dm)} "
                f"{num(g.fill_top)} units box",
                f"region insert_side plane {num(outlet_right - 0.6 * dm * math.sin(beta))} 0 "
                f"{num(g.hopper_bottom + 0.6 * dm * math.cos(beta))} {num(-math.sin(beta))} 0 "
                f"{num(math.cos(beta))} side in units box",
                "region insert intersect 2 insert_block insert_side",
            ]
        )
        self.insert_particles("insert", "the hopper")
        self.lmp.commands_list(
            [
                f"fix floor all wall/gran granular {pw} zplane 0.0 NULL",
                f"fix end_walls all wall/gran granular {pw} xplane 0.0 {num(g.box_right)}",
                f"region below_slide plane {num(g.slide_edge)} 0 {num(g.slide_edge_height)} "
                f"{num(math.sin(slide))} 0 {num(-math.cos(slide))} side in units box",
                f"region right_of_edge plane {num(g.slide_edge)} 0 0 1 0 0 side in units box",
                "region slide intersect 2 below_slide right_of_edge side out",
                f"fix slide all wall/gran/region granular {pw} region slide",
                f"region hopper_wall block {num(g.outlet_left - t)} {num(g.outlet_left)} INF INF "
                f"{num(g.hopper_bottom - t)} {num(g.hopper_top)} side out units box",
                f"fix hopper_wall all wall/gran/region granular {pw} region hopper_wall",
                f"region hopper_slope prism {num(outlet_right)} {num(outlet_right + t)} "
                f"{num(-depth)} {num(2.0 * depth)} {num(g.hopper_bottom)} {num(g.hopper_top)} "
                f"0 {num(wall_height / math.tan(beta))} 0 side out units box",
                f"fix hopper_slope all wall/gran/region granular {pw} region hopper_slope",
                f"region trapdoor block {num(g.outlet_left - t)} {num(outlet_right + t)} INF INF "
                f"{num(g.hopper_bottom - t)} {num(g.hopper_bottom)} side out units box",
                f"fix trapdoor all wall/gran/region granular {pw} region trapdoor",
            ]
        )
        self.start_dynamics()

    # -- masses ---------------------------------------------------------------
    def held_masses(self) -> tuple[float, float]:
        """Mass [kg] in the hopper, and in the hopper or on the slide (not yet on the floor)."""
        x, _, m = self.particles()
        in_hopper = x[:, 2] > self.g.hopper_bottom - self.g.wall_thickness
        on_the_way = in_hopper | (x[:, 0] > self.g.slide_edge)
        return float(m[in_hopper].sum()), float(m[on_the_way].sum())

    def discharge(self, until_slide_empty: bool) -> dict[str, np.ndarray]:
        """Open the trapdoor and sample the held masses until done; returns the records.

        Done means: the hopper is empty (or, with ``until_slide_empty``, the
        slide too), the material has come to rest (a clogged outlet or
        material stuck on the slide), or ``max_time`` has passed.
        """
        s = self.s
        self.lmp.command("unfix trapdoor")
        every = max(1, round(s["sample_interval"] / self.dt))
        limit = max(1, math.ceil(s["max_time"] / self.dt))
        empty = s["slide_empty_fraction"] * self.total_mass
        hopper, on_way = self.held_masses()
        times, held, remaining = [0.0], [hopper], [on_way]
        estimated, done = False, 0
        while done < limit:
            self.check_stop()
            step = min(every, limit - done)
            energy = self.advance(step, "discharge", allow_loss=False, container=CONTAINER)
            done += step
            hopper, on_way = self.held_masses()
            times.append(done * self.dt)
            held.append(hopper)
            remaining.append(on_way)
            discharged = 1.0 - hopper / self.total_mass
            estimate = None
            if not estimated and discharged >= EARLY_ESTIMATE_AT:
                estimated = True
                estimate = {
                    "mass_flow": measure.discharge_rate(
                        np.array(times),
                        np.array(held),
                        self.total_mass,
                        (MASS_FLOW_BAND[0], EARLY_ESTIMATE_AT),
                        s["max_time"],
                    )
                }
            self.monitor.progress(0.2 + 0.6 * done / limit, "discharge", estimate)
            finished = (on_way if until_slide_empty else hopper) < empty
            resting = done * self.dt >= MIN_FLOW_TIME and energy < self.rest_energy()
            if finished or resting:
                break
        return {"times": np.array(times), "held": np.array(held), "remaining": np.array(remaining)}

    # -- the test -------------------------------------------------------------
    def stages(self, measurements: dict[str, float], arrays: dict[str, np.ndarray]) -> None:
        wants = set(self.job.responses)
        fall_time = math.sqrt(2.0 * (self.g.fill_top - self.g.hopper_bottom) / GRAVITY)
        measurements["fill_at_rest"] = float(
            self.settle("fill", 0.0, 0.2, False, min_time=fall_time, container="the closed hopper")
        )
        record = self.discharge(until_slide_empty=bool(wants - {"mass_flow"}))
        arrays.update(
            discharge_time=record["times"],
            hopper_mass=record["held"],
            mass_on_the_way=record["remaining"],
        )
        if "mass_flow" in wants:
            measurements["mass_flow"] = measure.discharge_rate(
                record["times"], record["held"], self.total_mass, MASS_FLOW_BAND, self.s["max_time"]
            )
        if "slide_time" in wants:
            measurements["slide_time"] = measure.slide_time_with_penalty(
                record["times"],
                record["remaining"],
                self.total_mass,
                self.s["slide_empty_fraction"],
                self.s["max_time"],
            )
        if "angle_of_repose" in wants:
            measurements["pile_at_rest"] = float(
                self.settle("pile", 0.8, 1.0, False, container=CONTAINER)
            )
            x, r, _ = self.particles()
            arrays.update(heap_x=x, heap_r=r)


def run(job: SimulationJob, monitor: RunMonitor) -> RunResult:
    """The scene's LAMMPS driver: run one simulation (in the LAMMPS engine's child process)."""
    return CalibrationDevice(job, monitor).run()
