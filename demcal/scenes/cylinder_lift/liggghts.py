"""Cylinder lift on LIGGGHTS: the input files of one simulation (the scene's LIGGGHTS driver).

The LIGGGHTS engine (``demcal.engines.liggghts``) calls ``case(job)``, has
the case write its files into the run directory, runs the binary on them and
hands the case the dumps its script wrote (interface: ``LiggghtsCase`` there).

The case writes a data file with the spheres (same diameters as the LAMMPS
driver for the same seed, placed at random without overlap), ASCII STL meshes
of the cylinder and the rim ring, and an input script that runs the stages
fill/settle, lift and heap/settle in loops of
``demcal.engines.particles.CHUNK_TIME`` with the same rest and blow-up tests
as the LAMMPS driver. Dumps: ``fill.dump`` after the
fill has settled (fill_x, fill_r, fill_mass; early estimate of the bulk
density) and, when the angle of repose is asked for, ``heap.dump`` after the
heap has settled (heap_x, heap_r).

Contact model, against the LAMMPS driver (``demcal.engines.lammps_driver``):

- normal: Hertz with restitution damping (LIGGGHTS ``hertz``, LAMMPS
  ``hertz/material ... damping coeff_restitution``), same E* = E / (2 (1 - nu^2));
- tangential: LIGGGHTS ``history`` (k_t = 8 G* a, damped, Coulomb cap) where
  LAMMPS uses ``mindlin``: the same law up to the tangential damping factor;
- rolling: LIGGGHTS ``epsd`` is Ai et al.'s (2011) elastic-plastic
  spring-dashpot as used by Rackl & Hanley: k_r = 2.25 k_n mu_r^2 R*^2 with
  the *current* Hertz stiffness k_n, torque cap mu_r R* F_n, damping
  eta_r 2 sqrt(I_r k_r) with eta_r the ``rolling_damping_ratio``. LAMMPS'
  ``rolling sds`` uses a constant k_n (Hertz secant at a reference load), so
  the two engines agree in the cap and differ in the stiffness while the
  torque is below it. (``epsd2`` would take k_r = k_t R*^2, independent of
  mu_r, without damping: not the papers' model.) LIGGGHTS has no twisting
  resistance here; the LAMMPS driver adds ``twisting marshall``.

Geometry differences: the mesh cylinder has a lower rim that particles touch
(LAMMPS' open region cylinder has none), and the lift travel is taken from
the highest sphere centre instead of the mean fill height (about one
diameter more travel; the cylinder clears the material either way).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from demcal.engines.base import SimulationJob
from demcal.engines.lammps_driver import num
from demcal.engines.liggghts import SCRIPT, positions, write_ascii_stl
from demcal.engines.particles import BLOWUP_FACTOR, INSERTION_SOLID_FRACTION, simulation_particles
from demcal.errors import SimulationFailed
from demcal.physics import measure
from demcal.physics.contact import GRAVITY

DATA, TUBE_STL, RING_STL, FILL_DUMP, HEAP_DUMP = (
    "particles.data",
    "tube.stl",
    "ring.stl",
    "fill.dump",
    "heap.dump",
)
#: Largest deviation of the polygonal cylinder from the circle, in median diameters.
MESH_TOLERANCE = 0.01
#: Random placement tries per sphere before giving up (as LAMMPS' create_atoms maxtry).
MAX_TRIES = 1000


# -- geometry -----------------------------------------------------------------


def cylinder_triangles(
    radius: float, z_low: float, z_high: float, segments: int, rows: int
) -> np.ndarray:
    """Triangles (n, 3, 3) of the side of a vertical cylinder around the z axis, facing the axis.

    The circle is a polygon of ``segments`` vertices on the radius; the height is
    cut into ``rows`` bands of two triangles per segment, so the surface is closed
    around the circumference and open at both ends.
    """
    angles = 2.0 * math.pi * np.arange(segments + 1) / segments
    ring = np.stack([radius * np.cos(angles), radius * np.sin(angles)], axis=1)
    ring[-1] = ring[0]
    heights = np.linspace(z_low, z_high, rows + 1)
    triangles = []
    for z0, z1 in zip(heights[:-1], heights[1:]):
        for (x0, y0), (x1, y1) in zip(ring[:-1], ring[1:]):
            a, b, c, d = (x0, y0, z0), (x1, y1, z0), (x1, y1, z1), (x0, y0, z1)
            triangles += [(a, c, b), (a, d, c)]  # clockwise seen from outside: normal inward
    return np.array(triangles, dtype=float)


def polygon_segments(radius: float, tolerance: float) -> int:
    """Vertices of a circle polygon whose flats lie at most ``tolerance`` [m] inside the circle."""
    return max(16, math.ceil(math.pi / math.acos(max(1.0 - tolerance / radius, -1.0))))


def place_spheres(
    diameters: np.ndarray,
    radius: float,
    z_low: float,
    z_high: float,
    gap: float,
    rng: np.random.Generator,
) -> np.ndarray:
    """Random centres (N, 3) in a vertical cylinder around the z axis, at least ``gap`` apart.

    Random sequential addition with a cell list; each sphere gets ``MAX_TRIES``
    uniform tries. Raises SimulationFailed when one finds no place.
    """
    cells: dict[tuple[int, int, int], list[tuple[float, float, float]]] = {}
    centres = np.empty((len(diameters), 3))
    gap2 = gap * gap
    for i in range(len(diameters)):
        for _ in range(MAX_TRIES):
            rho, phi = radius * math.sqrt(rng.random()), 2.0 * math.pi * rng.random()
            p = (rho * math.cos(phi), rho * math.sin(phi), z_low + (z_high - z_low) * rng.random())
            key = (math.floor(p[0] / gap), math.floor(p[1] / gap), math.floor(p[2] / gap))
            if all(
                (p[0] - q[0]) ** 2 + (p[1] - q[1]) ** 2 + (p[2] - q[2]) ** 2 >= gap2
                for dx in (-1, 0, 1)
                for dy in (-1, 0, 1)
                for dz in (-1, 0, 1)
                for q in cells.get((key[0] + dx, key[1] + dy, key[2] + dz), ())
            ):
                cells.setdefault(key, []).append(p)
                centres[i] = p
                break
        else:
            raise SimulationFailed(
                f"could place only {i} of {len(diameters)} particles in the "
                f"cylinder; enlarge cylinder_diameter"
            )
    return centres


# -- input --------------------------------------------------------------------


def _type_pairs(particle_particle: float, particle_wall: float) -> str:
    """A 2 x 2 peratomtypepair matrix (type 1 particles, type 2 walls), row by row."""
    pw = num(particle_wall)
    return f"{num(particle_particle)} {pw} {pw} {pw}"


class CylinderLiftInput:
    """The LIGGGHTS input of one cylinder-lift simulation: numbers, files, script (SI units).

    Implements ``demcal.engines.liggghts.LiggghtsCase``.
    """

    def __init__(self, job: SimulationJob):
        self.job, self.p, self.s = job, job.parameters, job.settings
        self.rng = np.random.default_rng(job.seed)
        particles = simulation_particles(job, self.rng)
        self.diameters, self.d_max = particles.diameters, particles.d_max
        self.rayleigh, self.dt, self.chunk = (
            particles.rayleigh_time,
            particles.timestep,
            particles.chunk_steps,
        )
        cylinder_diameter: float = self.s["cylinder_diameter"]
        self.radius = cylinder_diameter / 2.0
        self.insert_radius = self.radius - 0.6 * self.d_max
        self.insert_top = 0.6 * self.d_max + particles.volume / (
            INSERTION_SOLID_FRACTION * math.pi * self.insert_radius**2
        )
        self.cylinder_top = self.insert_top + 2.0 * self.d_max
        self.total_mass = particles.mass
        self.wants_heap = "angle_of_repose" in job.responses

    # -- what the engine reads --------------------------------------------------

    @property
    def particle_count(self) -> int:
        return len(self.diameters)

    @property
    def stages(self) -> dict[str, tuple[float, float]]:
        """Progress share (from, to) of each stage the script reports, in run order."""
        if self.wants_heap:
            return {"fill": (0.0, 0.25), "lift": (0.25, 0.8), "heap": (0.8, 1.0)}
        return {"fill": (0.0, 1.0)}

    @property
    def dumps(self) -> dict[str, str]:
        """The dump file the script writes at the end of each stage that has one."""
        return {"fill": FILL_DUMP, **({"heap": HEAP_DUMP} if self.wants_heap else {})}

    def estimate(self, stage: str, dump: dict[str, np.ndarray]) -> dict[str, float]:
        """Early response estimates from the dump of ``stage``: the bulk density after the fill."""
        if stage != "fill":
            return {}
        bulk, _ = measure.fill_bulk_density(
            positions(dump), dump["radius"], dump["mass"], self.radius, self.s["d50"]
        )
        return {"bulk_density": bulk}

    def collect(
        self, stage: str, dump: dict[str, np.ndarray], at_rest: bool
    ) -> tuple[dict[str, float], dict[str, np.ndarray]]:
        """Measurements and the scene's arrays from the final dump of ``stage``.

        fill: fill_at_rest, fill_height; fill_x, fill_r, fill_mass (raises
        SimulationFailed if spheres left the closed cylinder). heap:
        heap_at_rest, lost_particles; heap_x, heap_r.
        """
        x = positions(dump)
        if stage == "fill":
            lost = self.particle_count - len(x)
            if lost:
                raise SimulationFailed(
                    f"unstable during fill: {lost} particles left the closed cylinder "
                    f"(time step {self.dt:.3g} s = {self.job.timestep_fraction:g} T_R)"
                )
            _, height = measure.fill_bulk_density(
                x, dump["radius"], dump["mass"], self.radius, self.s["d50"]
            )
            return (
                {"fill_at_rest": float(at_rest), "fill_height": height},
                {"fill_x": x, "fill_r": dump["radius"], "fill_mass": dump["mass"]},
            )
        return (
            {"heap_at_rest": float(at_rest), "lost_particles": float(self.particle_count - len(x))},
            {"heap_x": x, "heap_r": dump["radius"]},
        )

    # -- files --------------------------------------------------------------------

    def chunks(self, seconds: float) -> int:
        """Chunks of ``self.chunk`` steps covering ``seconds`` of simulated time."""
        return max(1, math.ceil(seconds / (self.chunk * self.dt)))

    @property
    def rest_energy(self) -> float:
        """Kinetic energy [J] below which the material is at rest (rms speed rest_speed)."""
        rest_speed: float = self.s["rest_speed"]
        return 0.5 * self.total_mass * rest_speed**2

    @property
    def blowup_energy(self) -> float:
        """Kinetic energy [J] above which the integration has blown up."""
        return BLOWUP_FACTOR * self.total_mass * GRAVITY * self.cylinder_top

    def write(self, workdir: Path) -> None:
        """Write the data file, the meshes and the script into ``workdir``."""
        if self.s["trim_height"] > 0.0:
            raise SimulationFailed(
                "trim_height (trimming the fill) runs on LAMMPS only; set it to 0 for LIGGGHTS"
            )
        half = self.s["plate_width"] / 2.0
        ring = self.s["ring_height"]
        centres = place_spheres(
            self.diameters,
            self.insert_radius,
            0.6 * self.d_max,
            self.insert_top,
            1.001 * self.d_max,
            self.rng,
        )
        z_low, z_high = -0.5 * self.d_max, 2.0 * self.cylinder_top + 5.0 * self.d_max
        rows = [
            f"{i + 1} 1 {num(d)} {num(self.p['particle_density'])} {num(x)} {num(y)} {num(z)}"
            for i, (d, (x, y, z)) in enumerate(zip(self.diameters, centres))
        ]
        (workdir / DATA).write_text(
            "\n".join(
                [
                    "demcal cylinder lift: spheres (id type diameter density x y z)",
                    "",
                    f"{len(rows)} atoms",
                    "2 atom types",
                    "",
                    f"{num(-half)} {num(half)} xlo xhi",
                    f"{num(-half)} {num(half)} ylo yhi",
                    f"{num(z_low)} {num(z_high)} zlo zhi",
                    "",
                    "Atoms",
                    "",
                    *rows,
                    "",
                ]
            )
        )
        segments = polygon_segments(self.radius, MESH_TOLERANCE * self.s["d50"])
        width = 2.0 * math.pi * self.radius / segments
        tube_rows = max(1, round((self.cylinder_top - ring) / (2.0 * width)))
        write_ascii_stl(
            workdir / TUBE_STL,
            "tube",
            cylinder_triangles(self.radius, ring, self.cylinder_top, segments, tube_rows),
        )
        if ring > 0.0:
            write_ascii_stl(
                workdir / RING_STL,
                "ring",
                cylinder_triangles(
                    self.radius, 0.0, ring, segments, max(1, round(ring / (2.0 * width)))
                ),
            )
        (workdir / SCRIPT).write_text(self.script())

    def script(self) -> str:
        """The LIGGGHTS input script (one command a line, paths relative to the run directory)."""
        p, s = self.p, self.s
        model = "model hertz tangential history rolling_friction epsd"
        meshes = ["tube"] + (["ring"] if s["ring_height"] > 0.0 else [])
        lines = [
            "# demcal cylinder lift on LIGGGHTS (generated), SI units",
            "units si",
            "atom_style granular",
            "atom_modify map array",
            "boundary f f f",
            "newton off",
            "communicate single vel yes",
            f"read_data {DATA}",
            f"neighbor {num(0.1 * self.d_max)} bin",
            "neigh_modify delay 0",
            f"fix m1 all property/global youngsModulus peratomtype "
            f"{num(p['youngs_modulus'])} {num(p['youngs_modulus'])}",
            f"fix m2 all property/global poissonsRatio peratomtype "
            f"{num(p['poisson_ratio'])} {num(p['poisson_ratio'])}",
            f"fix m3 all property/global coefficientRestitution peratomtypepair 2 "
            f"{_type_pairs(p['restitution_pp'], p['restitution_pw'])}",
            f"fix m4 all property/global coefficientFriction peratomtypepair 2 "
            f"{_type_pairs(p['sliding_friction_pp'], p['sliding_friction_pw'])}",
            f"fix m5 all property/global coefficientRollingFriction peratomtypepair 2 "
            f"{_type_pairs(p['rolling_friction_pp'], p['rolling_friction_pw'])}",
            f"fix m6 all property/global coefficientRollingViscousDamping peratomtypepair 2 "
            f"{_type_pairs(p['rolling_damping_ratio'], p['rolling_damping_ratio'])}",
            f"pair_style gran {model}",
            "pair_coeff * *",
            f"timestep {num(self.dt)}",
            f"fix gravity all gravity {num(GRAVITY)} vector 0 0 -1",
            f"fix floor all wall/gran {model} primitive type 2 zplane 0.0",
            f"fix tube all mesh/surface file {TUBE_STL} type 2",
            *([f"fix ring all mesh/surface file {RING_STL} type 2"] if len(meshes) > 1 else []),
            f"fix walls all wall/gran {model} mesh n_meshes {len(meshes)} "
            f"meshes {' '.join(meshes)}",
            "fix integrate all nve/sphere",
            "compute ke_t all ke",
            "compute ke_r all erotate/sphere",
            "compute ztop all reduce max z",
            "variable energy equal c_ke_t+c_ke_r",
            "variable now equal step",
            "thermo_style custom step atoms c_ke_t c_ke_r c_ztop",
            f"thermo {self.chunk}",
            "thermo_modify lost error norm no",
        ]
        if s.get("dump_interval", 0.0) > 0.0:
            every = max(1, round(s["dump_interval"] / self.dt))
            lines.append(f"dump particles all custom {every} dump.liggghts id x y z radius")
        fall_time = math.sqrt(2.0 * self.insert_top / GRAVITY)
        lines += self.settle_loop("fill", self.chunks(fall_time))
        lines.append(f"write_dump all custom {FILL_DUMP} id x y z radius mass")
        lines.append('print "demcal-dump fill"')
        if self.wants_heap:
            clearance = 0.5 * self.d_max + 2.0 * self.d_max - s["ring_height"]
            per_chunk = s["lift_speed"] * self.chunk * self.dt
            lines += [
                "thermo_modify lost ignore norm no",  # material may now leave over the plate edge
                f"variable lift_count equal ceil((c_ztop+{num(clearance)})/{num(per_chunk)})",
                "variable lift_chunks string ${lift_count}",
                f"fix lift all move/mesh mesh tube linear 0 0 {num(s['lift_speed'])}",
                "variable lift_i loop ${lift_chunks}",
                "label lift_loop",
                f"run {self.chunk} post no",
                'print "demcal-progress lift ${lift_i} ${lift_chunks} ${energy}"',
                f'if "${{energy}} > {num(self.blowup_energy)}" then "jump SELF unstable_lift"',
                "next lift_i",
                "jump SELF lift_loop",
                "unfix lift",
            ]
            lines += self.settle_loop("heap", 0)
            lines.append(f"write_dump all custom {HEAP_DUMP} id x y z radius mass")
            lines.append('print "demcal-dump heap"')
        lines += ['print "demcal-done ${now}"', "jump SELF finished"]
        for stage in ("fill", "lift", "heap"):
            lines += [
                f"label unstable_{stage}",
                f'print "demcal-unstable {stage} ${{energy}}"',
                "jump SELF finished",
            ]
        lines.append("label finished")
        return "\n".join(lines) + "\n"

    def settle_loop(self, stage: str, min_chunks: int) -> list[str]:
        """Run chunks until the material is at rest (after ``min_chunks``) or max_settle_time."""
        total = self.chunks(self.s["max_settle_time"])
        return [
            f"variable {stage}_i loop {total}",
            f"label {stage}_loop",
            f"run {self.chunk} post no",
            f'print "demcal-progress {stage} ${{{stage}_i}} {total} ${{energy}}"',
            f'if "${{energy}} > {num(self.blowup_energy)}" then "jump SELF unstable_{stage}"',
            f'if "${{energy}} < {num(self.rest_energy)} && ${{{stage}_i}} >= {min_chunks}" '
            f'then "jump SELF {stage}_rest"',
            f"next {stage}_i",
            f"jump SELF {stage}_loop",
            f'print "demcal-rest {stage} 0"',
            f"jump SELF {stage}_done",
            f"label {stage}_rest",
            f'print "demcal-rest {stage} 1"',
            f"label {stage}_done",
        ]


def case(job: SimulationJob) -> CylinderLiftInput:
    """The scene's LIGGGHTS driver: the input of one simulation."""
    return CylinderLiftInput(job)
