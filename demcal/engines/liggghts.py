"""LIGGGHTS engine: Debian's ``liggghts`` binary (LIGGGHTS-PUBLIC 3.8) runs the cylinder lift.

Per simulation the engine writes into the run directory a data file with
the spheres (same diameters as the LAMMPS engine for the same seed, placed at
random without overlap), ASCII STL meshes of the cylinder and the rim ring,
and an input script that runs the stages fill/settle, lift and heap/settle
in loops of ``CHUNK_TIME`` with the same rest and blow-up tests as the
LAMMPS driver. It then runs the binary as a child process (stdin closed, its
own log), forwards the progress lines the script prints to ``partial.csv``,
kills the child when the STOP file appears, and reads the particle dumps
written after the fill and after the heap into the arrays the scene's
extractors read (fill_x, fill_r, fill_mass, heap_x, heap_r).

Contact model, against the LAMMPS engine (``demcal.scenes.lammps_driver``):

- normal: Hertz with restitution damping (LIGGGHTS ``hertz``, LAMMPS
  ``hertz/material ... damping coeff_restitution``), same E* = E / (2 (1 - nu^2));
- tangential: LIGGGHTS ``history`` (k_t = 8 G* a, damped, Coulomb cap) where
  LAMMPS uses ``mindlin``: the same law up to the tangential damping factor;
- rolling: LIGGGHTS ``epsd`` is Ai et al.'s (2011) elastic-plastic
  spring-dashpot as used by Rackl & Hanley: k_r = 2.25 k_n mu_r^2 R*^2 with
  the *current* Hertz stiffness k_n, torque cap mu_r R* F_n, damping
  eta_r 2 sqrt(I_r k_r) with eta_r = ``ROLLING_DAMPING_RATIO``. LAMMPS'
  ``rolling sds`` uses a constant k_n (Hertz secant at a reference load), so
  the two engines agree in the cap and differ in the stiffness while the
  torque is below it. (``epsd2`` would take k_r = k_t R*^2, independent of
  mu_r, without damping: not the papers' model.) LIGGGHTS has no twisting
  resistance here; the LAMMPS engine adds ``twisting marshall``.

Geometry differences: the mesh cylinder has a lower rim that particles touch
(LAMMPS' open region cylinder has none), and the lift travel is taken from
the highest sphere centre instead of the mean fill height (about one
diameter more travel; the cylinder clears the material either way).
"""

from __future__ import annotations

import functools
import math
import os
import re
import resource
import shutil
import signal
import subprocess
import time
from pathlib import Path

import numpy as np

from demcal.contact import GRAVITY, ROLLING_DAMPING_RATIO
from demcal.engines.base import (FAILED, OK, TERMINATED, Engine, RunMonitor, RunResult,
                                 SimulationJob, signal_name)
from demcal.errors import ConfigError, SimulationFailed
from demcal.files import log_tail
from demcal.scenes import measure
from demcal.scenes.lammps_driver import BLOWUP_FACTOR, CHUNK_TIME, INSERTION_SOLID_FRACTION, num
from demcal.scenes.psd import diameter_range, sample_diameters
from demcal.timestep import rayleigh_time

BINARY = "liggghts"
INSTALL_HINT = "install it with: apt-get install liggghts (Debian/Ubuntu, LIGGGHTS 3.8)"
SCENES_SUPPORTED = ("cylinder_lift",)
SCRIPT, LOG, OUTPUT, DATA = "in.liggghts", "liggghts.log", "liggghts.out", "particles.data"
TUBE_STL, RING_STL, FILL_DUMP, HEAP_DUMP = "tube.stl", "ring.stl", "fill.dump", "heap.dump"
POLL_SECONDS = 0.5
GRACE_SECONDS = 10.0
#: Largest deviation of the polygonal cylinder from the circle, in median diameters.
MESH_TOLERANCE = 0.01
#: Random placement tries per sphere before giving up (as LAMMPS' create_atoms maxtry).
MAX_TRIES = 1000
PROGRESS = re.compile(r"^demcal-progress (\w+) (\d+) (\d+)")
STAGE_END = re.compile(r"^demcal-rest (\w+)")


@functools.lru_cache(maxsize=None)
def liggghts_version(binary: str) -> str:
    """The version banner of ``binary`` (e.g. 'LIGGGHTS-PUBLIC 3.8.0'), or 'not installed'."""
    path = shutil.which(binary)
    if path is None:
        return "not installed"
    try:
        out = subprocess.run([path, "-log", "none", "-h"], stdin=subprocess.DEVNULL,
                             capture_output=True, text=True, timeout=60, check=False).stdout
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"unknown ({exc})"
    match = re.search(r"Version (\S+ [\d.]+)", out)
    return match.group(1) if match else "unknown"


# -- geometry -----------------------------------------------------------------

def cylinder_triangles(radius: float, z_low: float, z_high: float, segments: int,
                       rows: int) -> np.ndarray:
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


def facet_normals(triangles: np.ndarray) -> np.ndarray:
    """Unit normals (right-hand rule over the vertex order) of triangles (n, 3, 3)."""
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    return normals / np.linalg.norm(normals, axis=1, keepdims=True)


def write_ascii_stl(path: Path, name: str, triangles: np.ndarray) -> None:
    """Write triangles (n, 3, 3) [m] as an ASCII STL solid with their normals."""
    lines = [f"solid {name}"]
    for tri, n in zip(triangles, facet_normals(triangles)):
        lines += [f"  facet normal {n[0]:.9e} {n[1]:.9e} {n[2]:.9e}", "    outer loop"]
        lines += [f"      vertex {v[0]:.9e} {v[1]:.9e} {v[2]:.9e}" for v in tri]
        lines += ["    endloop", "  endfacet"]
    lines.append(f"endsolid {name}")
    Path(path).write_text("\n".join(lines) + "\n")


def polygon_segments(radius: float, tolerance: float) -> int:
    """Vertices of a circle polygon whose flats lie at most ``tolerance`` [m] inside the circle."""
    return max(16, math.ceil(math.pi / math.acos(max(1.0 - tolerance / radius, -1.0))))


def place_spheres(diameters: np.ndarray, radius: float, z_low: float, z_high: float,
                  gap: float, rng: np.random.Generator) -> np.ndarray:
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
            key = tuple(math.floor(c / gap) for c in p)
            if all((p[0] - q[0])**2 + (p[1] - q[1])**2 + (p[2] - q[2])**2 >= gap2
                   for dx in (-1, 0, 1) for dy in (-1, 0, 1) for dz in (-1, 0, 1)
                   for q in cells.get((key[0] + dx, key[1] + dy, key[2] + dz), ())):
                cells.setdefault(key, []).append(p)
                centres[i] = p
                break
        else:
            raise SimulationFailed(f"could place only {i} of {len(diameters)} particles in the "
                                   f"cylinder; enlarge cylinder_diameter")
    return centres


# -- input --------------------------------------------------------------------

def _type_pairs(particle_particle: float, particle_wall: float) -> str:
    """A 2 x 2 peratomtypepair matrix (type 1 particles, type 2 walls), row by row."""
    pw = num(particle_wall)
    return f"{num(particle_particle)} {pw} {pw} {pw}"


class CylinderLiftInput:
    """The LIGGGHTS input of one cylinder-lift simulation: numbers, files, script (SI units)."""

    def __init__(self, job: SimulationJob):
        self.job, self.p, self.s = job, job.parameters, job.settings
        s = self.s
        self.rng = np.random.default_rng(job.seed)
        self.diameters = sample_diameters(s["particle_count"], s["d50"], s["sigma_ln"],
                                          s["psd_truncation"], self.rng)
        d_min, self.d_max = diameter_range(s["d50"], s["sigma_ln"], s["psd_truncation"])
        self.rayleigh = rayleigh_time(d_min / 2.0, self.p["particle_density"],
                                      self.p["youngs_modulus"], self.p["poisson_ratio"])
        self.dt = job.timestep_fraction * self.rayleigh
        self.chunk = max(50, round(CHUNK_TIME / self.dt))
        self.radius = s["cylinder_diameter"] / 2.0
        self.insert_radius = self.radius - 0.6 * self.d_max
        volume = float(np.sum(math.pi / 6.0 * self.diameters**3))
        self.insert_top = 0.6 * self.d_max + volume / (
            INSERTION_SOLID_FRACTION * math.pi * self.insert_radius**2)
        self.cylinder_top = self.insert_top + 2.0 * self.d_max
        self.total_mass = self.p["particle_density"] * volume
        self.wants_heap = "angle_of_repose" in job.responses

    def chunks(self, seconds: float) -> int:
        """Chunks of ``self.chunk`` steps covering ``seconds`` of simulated time."""
        return max(1, math.ceil(seconds / (self.chunk * self.dt)))

    @property
    def rest_energy(self) -> float:
        """Kinetic energy [J] below which the material is at rest (rms speed rest_speed)."""
        return 0.5 * self.total_mass * self.s["rest_speed"] ** 2

    @property
    def blowup_energy(self) -> float:
        """Kinetic energy [J] above which the integration has blown up."""
        return BLOWUP_FACTOR * self.total_mass * GRAVITY * self.cylinder_top

    def write(self, workdir: Path) -> None:
        """Write the data file, the meshes and the script into ``workdir``."""
        half = self.s["plate_width"] / 2.0
        ring = self.s["ring_height"]
        centres = place_spheres(self.diameters, self.insert_radius, 0.6 * self.d_max,
                                self.insert_top, 1.001 * self.d_max, self.rng)
        z_low, z_high = -0.5 * self.d_max, 2.0 * self.cylinder_top + 5.0 * self.d_max
        rows = [f"{i + 1} 1 {num(d)} {num(self.p['particle_density'])} "
                f"{num(x)} {num(y)} {num(z)}"
                for i, (d, (x, y, z)) in enumerate(zip(self.diameters, centres))]
        (workdir / DATA).write_text("\n".join([
            "demcal cylinder lift: spheres (id type diameter density x y z)", "",
            f"{len(rows)} atoms", "2 atom types", "",
            f"{num(-half)} {num(half)} xlo xhi", f"{num(-half)} {num(half)} ylo yhi",
            f"{num(z_low)} {num(z_high)} zlo zhi", "", "Atoms", "", *rows, ""]))
        segments = polygon_segments(self.radius, MESH_TOLERANCE * self.s["d50"])
        width = 2.0 * math.pi * self.radius / segments
        tube_rows = max(1, round((self.cylinder_top - ring) / (2.0 * width)))
        write_ascii_stl(workdir / TUBE_STL, "tube", cylinder_triangles(
            self.radius, ring, self.cylinder_top, segments, tube_rows))
        if ring > 0.0:
            write_ascii_stl(workdir / RING_STL, "ring", cylinder_triangles(
                self.radius, 0.0, ring, segments, max(1, round(ring / (2.0 * width)))))
        (workdir / SCRIPT).write_text(self.script())

    def script(self) -> str:
        """The LIGGGHTS input script (one command a line, paths relative to the run directory)."""
        p, s = self.p, self.s
        model = "model hertz tangential history rolling_friction epsd"
        meshes = ["tube"] + (["ring"] if s["ring_height"] > 0.0 else [])
        lines = [
            "# demcal cylinder lift on LIGGGHTS (generated), SI units",
            "units si", "atom_style granular", "atom_modify map array", "boundary f f f",
            "newton off", "communicate single vel yes", f"read_data {DATA}",
            f"neighbor {num(0.1 * self.d_max)} bin", "neigh_modify delay 0",
            f"fix m1 all property/global youngsModulus peratomtype "
            f"{num(p['youngs_modulus'])} {num(p['youngs_modulus'])}",
            f"fix m2 all property/global poissonsRatio peratomtype "
            f"{num(p['poisson_ratio'])} {num(p['poisson_ratio'])}",
            f"fix m3 all property/global coefficientRestitution peratomtypepair 2 "
            f"{_type_pairs(p['restitution'], p['restitution'])}",
            f"fix m4 all property/global coefficientFriction peratomtypepair 2 "
            f"{_type_pairs(p['sliding_friction_pp'], p['sliding_friction_pw'])}",
            f"fix m5 all property/global coefficientRollingFriction peratomtypepair 2 "
            f"{_type_pairs(p['rolling_friction_pp'], p['rolling_friction_pw'])}",
            f"fix m6 all property/global coefficientRollingViscousDamping peratomtypepair 2 "
            f"{_type_pairs(ROLLING_DAMPING_RATIO, ROLLING_DAMPING_RATIO)}",
            f"pair_style gran {model}", "pair_coeff * *",
            f"timestep {num(self.dt)}",
            f"fix gravity all gravity {num(GRAVITY)} vector 0 0 -1",
            f"fix floor all wall/gran {model} primitive type 2 zplane 0.0",
            f"fix tube all mesh/surface file {TUBE_STL} type 2",
            *([f"fix ring all mesh/surface file {RING_STL} type 2"] if len(meshes) > 1 else []),
            f"fix walls all wall/gran {model} mesh n_meshes {len(meshes)} "
            f"meshes {' '.join(meshes)}",
            "fix integrate all nve/sphere",
            "compute ke_t all ke", "compute ke_r all erotate/sphere",
            "compute ztop all reduce max z",
            "variable energy equal c_ke_t+c_ke_r", "variable now equal step",
            "thermo_style custom step atoms c_ke_t c_ke_r c_ztop",
            f"thermo {self.chunk}", "thermo_modify lost error norm no",
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
                "next lift_i", "jump SELF lift_loop",
                "unfix lift",
            ]
            lines += self.settle_loop("heap", 0)
            lines.append(f"write_dump all custom {HEAP_DUMP} id x y z radius mass")
            lines.append('print "demcal-dump heap"')
        lines += ['print "demcal-done ${now}"', "jump SELF finished"]
        for stage in ("fill", "lift", "heap"):
            lines += [f"label unstable_{stage}", f'print "demcal-unstable {stage} ${{energy}}"',
                      "jump SELF finished"]
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
            f"next {stage}_i", f"jump SELF {stage}_loop",
            f'print "demcal-rest {stage} 0"', f"jump SELF {stage}_done",
            f"label {stage}_rest", f'print "demcal-rest {stage} 1"',
            f"label {stage}_done",
        ]


def read_dump(path: Path) -> dict[str, np.ndarray]:
    """Columns of a LIGGGHTS custom dump (one snapshot), rows sorted by atom id."""
    lines = Path(path).read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ATOMS"))
    names = lines[header].split()[2:]
    values = np.array([row.split() for row in lines[header + 1:] if row.strip()], dtype=float)
    values = values.reshape(-1, len(names))
    values = values[np.argsort(values[:, names.index("id")])]
    return {name: values[:, k] for k, name in enumerate(names)}


# -- engine -------------------------------------------------------------------

def _printable(text: str) -> str:
    """``text`` without control and replacement characters (LIGGGHTS prints stray bytes)."""
    return "".join(c for c in text if c.isprintable() and c != "\ufffd").strip()


class LiggghtsEngine(Engine):
    """LIGGGHTS 3.8 as a child process per simulation (cylinder lift only)."""

    name = "liggghts"

    def check(self, scenes: list) -> None:
        if self.settings:
            raise ConfigError(f"engine liggghts: takes no settings, got {sorted(self.settings)}")
        if shutil.which(BINARY) is None:
            raise ConfigError(f"engine liggghts: the {BINARY!r} binary is not on PATH; "
                              f"{INSTALL_HINT}")
        for scene in scenes:
            if scene.name not in SCENES_SUPPORTED:
                raise ConfigError(f"engine liggghts: no LIGGGHTS input for scene {scene.name!r}; "
                                  f"supported: {', '.join(SCENES_SUPPORTED)}")

    def version(self) -> str:
        return f"liggghts {liggghts_version(BINARY)}"

    def run(self, job: SimulationJob, monitor: RunMonitor) -> RunResult:
        binary = shutil.which(BINARY)
        if binary is None:
            return RunResult(FAILED, f"the {BINARY!r} binary is not on PATH; {INSTALL_HINT}")
        if job.scene not in SCENES_SUPPORTED:
            return RunResult(FAILED, f"LIGGGHTS engine has no input for scene {job.scene!r}")
        workdir = Path(job.workdir).resolve()
        for stale in (FILL_DUMP, HEAP_DUMP, LOG):
            (workdir / stale).unlink(missing_ok=True)
        case = CylinderLiftInput(job)
        try:
            case.write(workdir)
        except SimulationFailed as exc:
            return RunResult(FAILED, str(exc))
        env = dict(os.environ, OMP_NUM_THREADS="1")
        start = time.monotonic()
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        with open(workdir / OUTPUT, "w") as out:
            proc = subprocess.Popen(  # no "-screen none": the mesh reader then segfaults
                [binary, "-in", SCRIPT, "-log", LOG, "-nocite"],
                cwd=workdir, stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT,
                env=env, start_new_session=True)
            stopped = self._watch(proc, monitor, case, workdir / LOG)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cost = {"wall_s": time.monotonic() - start,
                "cpu_s": (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime),
                "timestep_s": case.dt, "rayleigh_time_s": case.rayleigh}
        if stopped:
            return RunResult(TERMINATED, "stop requested", cost=cost)
        log = (workdir / LOG).read_text(errors="replace") if (workdir / LOG).exists() else ""
        steps = [int(m) for m in re.findall(r"^demcal-done (\d+)", log, re.M)]
        if steps:
            cost.update(steps=steps[0], particle_steps=float(steps[0] * len(case.diameters)),
                        simulated_time_s=steps[0] * case.dt)
        reason = self._failure(proc.returncode, log, workdir, case, bool(steps))
        if reason:
            return RunResult(FAILED, reason, cost=cost)
        try:
            measurements, arrays = self._state(case, log, workdir)
        except SimulationFailed as exc:
            return RunResult(FAILED, str(exc), cost=cost)
        return RunResult(OK, measurements=measurements, arrays=arrays, cost=cost)

    @staticmethod
    def _watch(proc, monitor: RunMonitor, case: CylinderLiftInput, log: Path) -> bool:
        """Wait for the child, forwarding its progress lines; kill it on STOP (returns True)."""
        shares = ({"fill": (0.0, 0.25), "lift": (0.25, 0.8), "heap": (0.8, 1.0)}
                  if case.wants_heap else {"fill": (0.0, 1.0)})
        offset = 0
        while True:
            finished = proc.poll() is not None
            if not finished and monitor.stop_requested():
                os.killpg(proc.pid, signal.SIGTERM)
                try:
                    proc.wait(GRACE_SECONDS)
                except subprocess.TimeoutExpired:
                    os.killpg(proc.pid, signal.SIGKILL)
                    proc.wait()
                return True
            try:
                with open(log, "rb") as handle:
                    handle.seek(offset)
                    text = handle.read()
            except FileNotFoundError:
                text = b""
            complete = text[:text.rfind(b"\n") + 1]  # a line still being written waits
            offset += len(complete)
            for line in complete.decode(errors="replace").splitlines():
                progress, stage_end = PROGRESS.match(line), STAGE_END.match(line)
                if progress and progress.group(1) in shares:
                    low, high = shares[progress.group(1)]
                    fraction = int(progress.group(2)) / int(progress.group(3))
                    monitor.progress(low + (high - low) * fraction, progress.group(1))
                elif stage_end and stage_end.group(1) in shares:
                    monitor.progress(shares[stage_end.group(1)][1], stage_end.group(1))
                elif line.startswith("demcal-dump fill"):
                    try:
                        fill = read_dump(log.parent / FILL_DUMP)
                        x = np.stack([fill["x"], fill["y"], fill["z"]], axis=1)
                        bulk, _ = measure.fill_bulk_density(x, fill["radius"], fill["mass"],
                                                            case.radius, case.s["d50"])
                    except (OSError, ValueError, KeyError, StopIteration, SimulationFailed):
                        continue  # no early estimate; the final check reports the cause
                    monitor.progress(shares["fill"][1], "fill", {"bulk_density": bulk})
            if finished:
                return False
            try:
                proc.wait(POLL_SECONDS)
            except subprocess.TimeoutExpired:
                pass

    @staticmethod
    def _failure(returncode: int, log: str, workdir: Path, case: CylinderLiftInput,
                 done: bool) -> str:
        """Why the run failed ('' if it did not): signal, ERROR line, blow-up, early end."""
        tail = _printable(log_tail(workdir / LOG, 3) or log_tail(workdir / OUTPUT, 3))
        if returncode < 0:
            return f"LIGGGHTS died from {signal_name(returncode)} (log: {tail})"
        errors = [line.strip() for line in log.splitlines() if line.startswith("ERROR")]
        errors += [line.strip() for line in (workdir / OUTPUT).read_text(errors="replace")
                   .splitlines() if line.startswith("ERROR")] if not errors else []
        if errors:
            hint = (f" (time step {case.dt:.3g} s = {case.job.timestep_fraction:g} T_R too large?)"
                    if "Lost atoms" in errors[0] else "")
            error = _printable(errors[0].removeprefix("ERROR: "))
            return f"LIGGGHTS error: {error}{hint} | log: {tail}"
        if returncode != 0:
            return f"LIGGGHTS exited with code {returncode}: {tail}"
        unstable = re.search(r"^demcal-unstable (\w+) (\S+)", log, re.M)
        if unstable:
            return (f"unstable during {unstable.group(1)}: kinetic energy {unstable.group(2)} J "
                    f"exceeds {BLOWUP_FACTOR:g} times the potential energy of the material; "
                    f"time step {case.dt:.3g} s ({case.job.timestep_fraction:g} T_R) too large "
                    f"for this stiffness?")
        if not done:
            return f"LIGGGHTS stopped before the end of its script: {tail}"
        return ""

    @staticmethod
    def _state(case: CylinderLiftInput, log: str,
               workdir: Path) -> tuple[dict[str, float], dict[str, np.ndarray]]:
        """Measurements and particle arrays from the dumps; checks count and finiteness."""
        rest = dict(re.findall(r"^demcal-rest (\w+) ([01])", log, re.M))
        measurements: dict[str, float] = {"fill_at_rest": float(rest.get("fill", 0))}
        arrays: dict[str, np.ndarray] = {}
        dumps = [("fill", FILL_DUMP)] + ([("heap", HEAP_DUMP)] if case.wants_heap else [])
        for stage, name in dumps:
            try:
                data = read_dump(workdir / name)
            except (OSError, ValueError, StopIteration) as exc:
                raise SimulationFailed(f"LIGGGHTS {stage} dump {name} unreadable: {exc}") from None
            x = np.stack([data["x"], data["y"], data["z"]], axis=1)
            if not (np.isfinite(x).all() and np.isfinite(data["radius"]).all()):
                raise SimulationFailed(f"unstable: non-finite particle positions after {stage}")
            if stage == "fill":
                lost = len(case.diameters) - len(x)
                if lost:
                    raise SimulationFailed(
                        f"unstable during fill: {lost} particles left the closed cylinder "
                        f"(time step {case.dt:.3g} s = {case.job.timestep_fraction:g} T_R)")
                _, measurements["fill_height"] = measure.fill_bulk_density(
                    x, data["radius"], data["mass"], case.radius, case.s["d50"])
                arrays.update(fill_x=x, fill_r=data["radius"], fill_mass=data["mass"])
            else:
                measurements["heap_at_rest"] = float(rest.get("heap", 0))
                measurements["lost_particles"] = float(len(case.diameters) - len(x))
                arrays.update(heap_x=x, heap_r=data["radius"])
        return measurements, arrays
