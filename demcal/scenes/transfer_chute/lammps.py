"""Transfer chute on LAMMPS: feed a belt, throw into the tilted funnel, split on the divider.

Runs inside the LAMMPS engine's child process. Every part is a granular wall
on a region (``demcal.scenes.transfer_chute.ChuteGeometry``): the belt's
carrying side, its skirts and tail plate are frictionless blocks; the funnel
is two cones with open ends, its inner surface (material inside) and its
outer one (material that misses the opening), tilted about the pivot by a
constant rotation; the divider is a block reaching from the box's floor to
its top. Material is generated in batches on the belt, moving at the belt
speed. Every ``sample_interval`` the spheres below z = 0 are weighed, by the
side of the divider they are on, and deleted.
"""

from __future__ import annotations

import math

import numpy as np

from demcal.engines.base import RunMonitor, RunResult, SimulationJob
from demcal.engines.lammps_driver import LammpsDriver, contact_model, num, setup_commands
from demcal.errors import SimulationFailed
from demcal.physics.contact import GRAVITY
from demcal.scenes.transfer_chute import FEED_MARGIN, chute_geometry, expected_particle_mass

#: Thickness of the funnel's and the belt's plates [m].
PLATE = 0.02
#: Most solid fraction of a batch in the zone it is generated in.
BATCH_SOLID_FRACTION = 0.08
#: Depth below z = 0 the box reaches, room for what falls between two counts [m].
SUMP = 1.0


def window_rate(times: np.ndarray, delivered: np.ndarray, start: float, end: float) -> float:
    """Mass per second [kg/s] delivered between the first count at or after ``start`` and the
    last at or before ``end`` (cumulative ``delivered`` [kg] at ``times`` [s])."""
    inside = np.flatnonzero((times >= start - 1e-12) & (times <= end + 1e-12))
    if len(inside) < 2:
        raise SimulationFailed(
            f"fewer than two counts of the delivered mass in [{start:g}, {end:g}] s"
        )
    first, last = inside[0], inside[-1]
    return float((delivered[last] - delivered[first]) / (times[last] - times[first]))


def flow_responses(left: float, right: float) -> dict[str, float]:
    """The four responses of the left and right mass flows [kg/s]."""
    total = left + right
    if total <= 0.0:
        raise SimulationFailed("no material reached the chutes in the steady window")
    return {
        "mass_flow_left": left,
        "mass_flow_right": right,
        "flow_difference": left - right,
        "split": left / total,
    }


class TransferChute(LammpsDriver):
    """One LAMMPS simulation of the chute; ``run`` drives the feed."""

    def __init__(self, job: SimulationJob, monitor: RunMonitor):
        s = job.settings
        fed = s["feed_rate"] * s["feed_time"]
        count = math.ceil(
            FEED_MARGIN * fed / expected_particle_mass(s, job.parameters["particle_density"])
        )
        super().__init__(job, monitor, count)
        self.g = chute_geometry(self.s)
        self.potential_height = self.g.belt_height + SUMP + s["belt_speed"] ** 2 / (2 * GRAVITY)
        self.inserted = self.next_particle = self.batches = 0  # fed in batches

    # -- geometry -------------------------------------------------------------
    def belt_ends(self) -> tuple[float, float]:
        """y of the belt's tail and end [m]."""
        head = -self.g.belt_reach
        return head - self.g.belt_length, head

    def build(self) -> None:
        g, dm = self.g, self.d_max
        tail, head = self.belt_ends()
        top = g.belt_height
        y_far = max(g.pivot_y + g.top_radius, 0.0) + 1.0
        frictionless = contact_model(
            {
                **self.p,
                "sliding_friction_pw": 0.0,
                "rolling_friction_pw": 0.0,
            },
            self.s,
            wall=True,
        )
        pivot = f"0 {num(g.pivot_y)} {num(g.pivot_z)}"
        bottom = g.pivot_z - g.funnel_depth
        self.lmp.commands_list(
            [
                *setup_commands("f f f"),
                f"region box block {num(-g.half_width)} {num(g.half_width)} "
                f"{num(tail - PLATE - 2 * dm)} {num(y_far)} {num(-SUMP)} {num(top + 0.6)} "
                f"units box",
                "create_box 1 box",
                "pair_style granular",
                f"pair_coeff * * {self.pair_model()}",
                f"neighbor {num(0.1 * dm)} bin",
                "neigh_modify delay 0 every 1 check yes",
                f"fix side_walls all wall/gran granular {self.wall_model()} xplane "
                f"{num(-g.half_width)} {num(g.half_width)}",
                f"fix end_walls all wall/gran granular {self.wall_model()} yplane "
                f"{num(tail - PLATE - 2 * dm)} {num(y_far)}",
                # the belt: its carrying side, skirts and tail plate
                f"region belt_plate block {num(-g.belt_width / 2)} {num(g.belt_width / 2)} "
                f"{num(tail)} {num(head)} {num(top - PLATE)} {num(top)} units box",
                f"region skirt_left block {num(-g.belt_width / 2 - PLATE)} "
                f"{num(-g.belt_width / 2)} {num(tail)} {num(head)} {num(top)} {num(top + 0.5)} "
                f"units box",
                f"region skirt_right block {num(g.belt_width / 2)} "
                f"{num(g.belt_width / 2 + PLATE)} {num(tail)} {num(head)} {num(top)} "
                f"{num(top + 0.5)} units box",
                f"region tail_plate block {num(-g.belt_width / 2)} {num(g.belt_width / 2)} "
                f"{num(tail - PLATE)} {num(tail)} {num(top)} {num(top + 0.5)} units box",
                "region belt union 4 belt_plate skirt_left skirt_right tail_plate side out",
                f"fix belt all wall/gran/region granular {frictionless} region belt",
                # the funnel, tilted about its pivot by a constant rotation
                f"variable tilt equal {num(g.tilt)}",
                f"region funnel_in cone z 0 {num(g.pivot_y)} {num(g.outlet_radius)} "
                f"{num(g.top_radius)} {num(bottom)} {num(g.pivot_z)} side in open 1 open 2 "
                f"units box rotate v_tilt {pivot} 1 0 0",
                f"region funnel_out cone z 0 {num(g.pivot_y)} {num(g.outlet_radius + PLATE)} "
                f"{num(g.top_radius + PLATE)} {num(bottom)} {num(g.pivot_z)} side out open 1 "
                f"open 2 units box rotate v_tilt {pivot} 1 0 0",
                f"fix funnel_inside all wall/gran/region granular {self.wall_model()} "
                f"region funnel_in",
                f"fix funnel_outside all wall/gran/region granular {self.wall_model()} "
                f"region funnel_out",
                # the divider, down through the sump so that each side's count stays its own
                f"region divider block INF INF {num(-g.divider_thickness / 2)} "
                f"{num(g.divider_thickness / 2)} {num(-SUMP - 1.0)} {num(g.divider_height)} "
                f"side out units box",
                f"fix divider all wall/gran/region granular {self.wall_model()} region divider",
                f"region delivered block INF INF INF INF {num(-SUMP - 1.0)} 0 units box",
            ]
        )
        self.start_dynamics()

    # -- feeding --------------------------------------------------------------
    def feed_zone(self) -> tuple[str, float]:
        """Create the zone a batch is generated in, at the belt's tail; returns its name and the
        time [s] the belt takes to carry a batch out of it (the interval between batches)."""
        g, dm, s = self.g, self.d_max, self.s
        tail, head = self.belt_ends()
        length = min(max(3.0 * dm, 0.2), 0.5 * (head - tail))
        width = g.belt_width - 1.2 * dm
        interval = length / s["belt_speed"]
        volume = s["feed_rate"] * interval / self.p["particle_density"]
        height = max(3.0 * dm, volume / (BATCH_SOLID_FRACTION * width * length))
        self.lmp.command(
            f"region feed block {num(-width / 2)} {num(width / 2)} {num(tail + 0.6 * dm)} "
            f"{num(tail + 0.6 * dm + length)} {num(g.belt_height + 0.6 * dm)} "
            f"{num(g.belt_height + 0.6 * dm + height)} units box"
        )
        return "feed", interval

    def feed_batch(self, zone: str, mass: float) -> float:
        """Generate the next spheres of the sample in ``zone``, moving at the belt speed, as
        many as make up ``mass`` [kg] without passing it; returns the mass placed (less when
        the zone is too full: the caller carries the rest over to the next batch)."""
        masses = self.p["particle_density"] * math.pi / 6.0 * self.diameters**3
        start = self.next_particle
        end = start + int(np.searchsorted(np.cumsum(masses[start:]), mass, side="right"))
        if end <= start:
            return 0.0
        before = self.lmp.get_natoms()
        self.batches += 1
        self.lmp.command(
            f"create_atoms 1 random {end - start} {self.job.seed + self.batches} {zone} "
            f"overlap {num(1.001 * self.d_max)} maxtry 1000"
        )
        placed = self.lmp.get_natoms() - before
        new = slice(before, before + placed)
        self.lmp.numpy.extract_atom("radius")[new] = self.diameters[start : start + placed] / 2
        self.lmp.command(f"set type 1 density {num(self.p['particle_density'])}")
        velocity = self.lmp.numpy.extract_atom("v")
        velocity[new] = (0.0, self.s["belt_speed"], 0.0)
        self.next_particle += placed
        self.inserted += placed
        return float(masses[start : start + placed].sum())

    def deliver(self) -> tuple[float, float]:
        """Weigh the spheres below z = 0 on each side of the divider [kg], and delete them."""
        x, _, m = self.particles()
        below = x[:, 2] < 0.0
        left = float(m[below & (x[:, 1] < 0.0)].sum())
        right = float(m[below & (x[:, 1] >= 0.0)].sum())
        if below.any():
            before = self.lmp.get_natoms()
            self.lmp.command("delete_atoms region delivered")
            self.removed += before - self.lmp.get_natoms()
        return left, right

    # -- the run --------------------------------------------------------------
    def stages(self, measurements: dict[str, float], arrays: dict[str, np.ndarray]) -> None:
        s = self.s
        zone, interval = self.feed_zone()
        sample_steps = max(1, round(s["sample_interval"] / self.dt))
        limit = math.ceil(s["feed_time"] / self.dt)
        window = (s["steady_from"], s["feed_time"])
        estimate_at = 0.5 * (window[0] + window[1])
        times, left, right = [0.0], [0.0], [0.0]
        fed, next_batch, done, estimated = 0.0, 0.0, 0, False
        while done < limit:
            self.check_stop()
            if done * self.dt >= next_batch:
                next_batch += interval
                due = s["feed_rate"] * min(next_batch, s["feed_time"])
                fed += self.feed_batch(zone, due - fed)
            batch_steps = max(1, math.ceil((next_batch - done * self.dt) / self.dt))
            step = min(sample_steps - done % sample_steps, batch_steps, limit - done)
            self.advance(step, "feed", allow_loss=False, container="the chute")
            done += step
            if done % sample_steps and done < limit:
                continue
            delivered = self.deliver()
            times.append(done * self.dt)
            left.append(left[-1] + delivered[0])
            right.append(right[-1] + delivered[1])
            estimate = None
            if not estimated and times[-1] >= estimate_at:
                estimated = True
                t = np.array(times)
                estimate = flow_responses(
                    window_rate(t, np.array(left), window[0], times[-1]),
                    window_rate(t, np.array(right), window[0], times[-1]),
                )
            self.monitor.progress(done / limit, "feed", estimate)
        t = np.array(times)
        arrays.update(
            delivery_time=t, delivered_left=np.array(left), delivered_right=np.array(right)
        )
        measurements["fed_mass"] = fed
        measurements.update(
            flow_responses(
                window_rate(t, arrays["delivered_left"], *window),
                window_rate(t, arrays["delivered_right"], *window),
            )
        )


def run(job: SimulationJob, monitor: RunMonitor) -> RunResult:
    """The scene's LAMMPS driver: run one simulation (in the LAMMPS engine's child process)."""
    return TransferChute(job, monitor).run()
