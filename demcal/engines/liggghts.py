"""LIGGGHTS engine: Debian's ``liggghts`` binary (LIGGGHTS-PUBLIC 3.8), a child process per run.

What to simulate comes from the driver the engine receives, a scene's
function ``driver(job)`` (e.g. ``demcal.scenes.cylinder_lift.liggghts.case``)
that returns a ``LiggghtsCase``, which writes the input files
(``in.liggghts`` and whatever it reads) into the run directory and turns the
particle dumps its script writes into measurements and the arrays the
scene's extractors read. The engine runs the binary on them (stdin closed,
its own log, one thread), forwards the progress lines the script prints to
``partial.csv``, kills the child when the STOP file appears, and turns a
signal death, an ``ERROR`` line, a non-zero exit, a blow-up or an early end
into a failed result with its reason.

The script reports to the engine by ``print`` lines in its log:

- ``demcal-progress STAGE I N ENERGY``: chunk I of at most N of STAGE is done;
- ``demcal-rest STAGE 1`` (at rest) or ``demcal-rest STAGE 0`` (time limit): STAGE ended;
- ``demcal-dump STAGE``: the dump of STAGE (``LiggghtsCase.dumps``) is complete;
- ``demcal-unstable STAGE ENERGY``: the kinetic energy exceeded ``BLOWUP_FACTOR``
  times the potential energy of the material; the script ends;
- ``demcal-done STEP``: the script reached its end after STEP time steps.
"""

from __future__ import annotations

import functools
import os
import re
import resource
import shutil
import subprocess
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Protocol

import numpy as np

from demcal.engines.base import (
    DeclaredScene,
    Engine,
    RunMonitor,
    RunResult,
    SimulationJob,
    signal_name,
    stop_process_group,
)
from demcal.engines.particles import BLOWUP_FACTOR
from demcal.errors import ConfigError, SimulationFailed
from demcal.physics.timestep import ADHESION_PARAMETERS
from demcal.results.records import Status
from demcal.results.storage import log_tail

BINARY = "liggghts"
INSTALL_HINT = "install it with: apt-get install liggghts (Debian/Ubuntu, LIGGGHTS 3.8)"
SCRIPT, LOG, OUTPUT = "in.liggghts", "liggghts.log", "liggghts.out"
POLL_SECONDS = 0.5
PROGRESS = re.compile(r"^demcal-progress (\w+) (\d+) (\d+)")
STAGE_END = re.compile(r"^demcal-rest (\w+)")
DUMP_DONE = re.compile(r"^demcal-dump (\w+)")


class LiggghtsCase(Protocol):
    """One simulation as a scene's LIGGGHTS driver describes it (``driver(job)``)."""

    dt: float  #: time step [s]
    rayleigh: float  #: Rayleigh time [s] of the smallest sphere
    particle_count: int  #: spheres at the start
    stages: dict[str, tuple[float, float]]  #: progress share (from, to) of each reported stage
    dumps: dict[str, str]  #: stage -> dump file (custom, with id x y z radius ...) it ends with

    def write(self, workdir: Path) -> None:
        """Write ``SCRIPT`` and the files it reads; raise SimulationFailed if impossible."""

    def estimate(self, stage: str, dump: dict[str, np.ndarray]) -> dict[str, float]:
        """Early response estimates from a stage's dump ({} for none)."""

    def collect(
        self, stage: str, dump: dict[str, np.ndarray], at_rest: bool
    ) -> tuple[dict[str, float], dict[str, np.ndarray]]:
        """Measurements and arrays from a stage's final dump; may raise SimulationFailed."""


@functools.cache
def liggghts_version(binary: str) -> str:
    """The version banner of ``binary`` (e.g. 'LIGGGHTS-PUBLIC 3.8.0'), or 'not installed'."""
    path = shutil.which(binary)
    if path is None:
        return "not installed"
    try:
        out = subprocess.run(
            [path, "-log", "none", "-h"],
            stdin=subprocess.DEVNULL,
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        ).stdout
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"unknown ({exc})"
    match = re.search(r"Version (\S+ [\d.]+)", out)
    return match.group(1) if match else "unknown"


# -- files --------------------------------------------------------------------


def facet_normals(triangles: np.ndarray) -> np.ndarray:
    """Unit normals (right-hand rule over the vertex order) of triangles (n, 3, 3)."""
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    unit: np.ndarray = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    return unit


def write_ascii_stl(path: Path, name: str, triangles: np.ndarray) -> None:
    """Write triangles (n, 3, 3) [m] as an ASCII STL solid (``fix mesh/surface``) with normals."""
    lines = [f"solid {name}"]
    for tri, n in zip(triangles, facet_normals(triangles)):
        lines += [f"  facet normal {n[0]:.9e} {n[1]:.9e} {n[2]:.9e}", "    outer loop"]
        lines += [f"      vertex {v[0]:.9e} {v[1]:.9e} {v[2]:.9e}" for v in tri]
        lines += ["    endloop", "  endfacet"]
    lines.append(f"endsolid {name}")
    Path(path).write_text("\n".join(lines) + "\n")


def read_dump(path: Path) -> dict[str, np.ndarray]:
    """Columns of a LIGGGHTS custom dump (one snapshot), rows sorted by atom id."""
    lines = Path(path).read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ATOMS"))
    names = lines[header].split()[2:]
    values = np.array([row.split() for row in lines[header + 1 :] if row.strip()], dtype=float)
    values = values.reshape(-1, len(names))
    values = values[np.argsort(values[:, names.index("id")])]
    return {name: values[:, k] for k, name in enumerate(names)}


def positions(dump: dict[str, np.ndarray]) -> np.ndarray:
    """Centres (N, 3) from a dump's x, y, z columns."""
    return np.stack([dump["x"], dump["y"], dump["z"]], axis=1)


# -- engine -------------------------------------------------------------------


def _printable(text: str) -> str:
    """``text`` without control and replacement characters (LIGGGHTS prints stray bytes)."""
    return "".join(c for c in text if c.isprintable() and c != "\ufffd").strip()


class LiggghtsEngine(Engine):
    """LIGGGHTS 3.8 as a child process per simulation (scenes with a LIGGGHTS driver)."""

    name = "liggghts"

    #: demcal's LIGGGHTS drivers have no JKR adhesion (LIGGGHTS' own cohesion models, SJKR,
    #: take another parameter, a cohesion energy density).
    UNMODELLED_PARAMETERS = ADHESION_PARAMETERS

    def check(self, scenes: Sequence[DeclaredScene]) -> None:
        if self.settings:
            raise ConfigError(f"engine liggghts: takes no settings, got {sorted(self.settings)}")
        if shutil.which(BINARY) is None:
            raise ConfigError(
                f"engine liggghts: the {BINARY!r} binary is not on PATH; {INSTALL_HINT}"
            )
        for scene in scenes:
            if scene.driver(self.name) is None:
                raise ConfigError(f"engine liggghts: no LIGGGHTS driver for scene {scene.name!r}")

    def version(self) -> str:
        return f"liggghts {liggghts_version(BINARY)}"

    def run(
        self,
        job: SimulationJob,
        monitor: RunMonitor,
        driver: Callable[[SimulationJob], LiggghtsCase] | None,
    ) -> RunResult:
        binary = shutil.which(BINARY)
        if binary is None:
            return RunResult(Status.FAILED, f"the {BINARY!r} binary is not on PATH; {INSTALL_HINT}")
        if driver is None:
            return RunResult(
                Status.FAILED, f"LIGGGHTS engine has no driver for scene {job.scene!r}"
            )
        case: LiggghtsCase = driver(job)
        workdir = Path(job.workdir).resolve()
        for stale in (*case.dumps.values(), LOG):
            (workdir / stale).unlink(missing_ok=True)
        try:
            case.write(workdir)
        except SimulationFailed as exc:
            return RunResult(Status.FAILED, str(exc))
        env = dict(os.environ, OMP_NUM_THREADS="1")
        start = time.monotonic()
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        with open(workdir / OUTPUT, "w") as out:
            proc = subprocess.Popen(  # no "-screen none": the mesh reader then segfaults
                [binary, "-in", SCRIPT, "-log", LOG, "-nocite"],
                cwd=workdir,
                stdin=subprocess.DEVNULL,
                stdout=out,
                stderr=subprocess.STDOUT,
                env=env,
                start_new_session=True,
            )
            stopped = self._watch(proc, monitor, case, workdir / LOG)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cost = {
            "wall_s": time.monotonic() - start,
            "cpu_s": (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime),
            "timestep_s": case.dt,
            "rayleigh_time_s": case.rayleigh,
        }
        if stopped:
            return RunResult(Status.TERMINATED, "stop requested", cost=cost)
        log = (workdir / LOG).read_text(errors="replace") if (workdir / LOG).exists() else ""
        steps = [int(m) for m in re.findall(r"^demcal-done (\d+)", log, re.M)]
        if steps:
            cost.update(
                steps=steps[0],
                particle_steps=float(steps[0] * case.particle_count),
                simulated_time_s=steps[0] * case.dt,
            )
        reason = self._failure(proc.returncode, log, workdir, job, case.dt, bool(steps))
        if reason:
            return RunResult(Status.FAILED, reason, cost=cost)
        try:
            measurements, arrays = self._state(case, log, workdir)
        except SimulationFailed as exc:
            return RunResult(Status.FAILED, str(exc), cost=cost)
        return RunResult(Status.OK, measurements=measurements, arrays=arrays, cost=cost)

    @staticmethod
    def _watch(
        proc: subprocess.Popen[bytes], monitor: RunMonitor, case: LiggghtsCase, log: Path
    ) -> bool:
        """Wait for the child, forwarding its progress lines; kill it on STOP (returns True)."""
        shares = case.stages
        offset = 0
        while True:
            finished = proc.poll() is not None
            if not finished and monitor.stop_requested():
                stop_process_group(proc)
                return True
            try:
                with open(log, "rb") as handle:
                    handle.seek(offset)
                    text = handle.read()
            except FileNotFoundError:
                text = b""
            complete = text[: text.rfind(b"\n") + 1]  # a line still being written waits
            offset += len(complete)
            for line in complete.decode(errors="replace").splitlines():
                progress, stage_end = PROGRESS.match(line), STAGE_END.match(line)
                dumped = DUMP_DONE.match(line)
                if progress and progress.group(1) in shares:
                    low, high = shares[progress.group(1)]
                    fraction = int(progress.group(2)) / int(progress.group(3))
                    monitor.progress(low + (high - low) * fraction, progress.group(1))
                elif stage_end and stage_end.group(1) in shares:
                    monitor.progress(shares[stage_end.group(1)][1], stage_end.group(1))
                elif dumped and dumped.group(1) in case.dumps and dumped.group(1) in shares:
                    stage = dumped.group(1)
                    try:
                        estimates = case.estimate(stage, read_dump(log.parent / case.dumps[stage]))
                    except (OSError, ValueError, KeyError, StopIteration, SimulationFailed):
                        continue  # no early estimate; the final check reports the cause
                    if estimates:
                        monitor.progress(shares[stage][1], stage, estimates)
            if finished:
                return False
            try:
                proc.wait(POLL_SECONDS)
            except subprocess.TimeoutExpired:
                pass

    @staticmethod
    def _failure(
        returncode: int, log: str, workdir: Path, job: SimulationJob, dt: float, done: bool
    ) -> str:
        """Why the run failed ('' if it did not): signal, ERROR line, blow-up, early end."""
        tail = _printable(log_tail(workdir / LOG, 3) or log_tail(workdir / OUTPUT, 3))
        if returncode < 0:
            return f"LIGGGHTS died from {signal_name(returncode)} (log: {tail})"
        errors = [line.strip() for line in log.splitlines() if line.startswith("ERROR")]
        errors += (
            [
                line.strip()
                for line in (workdir / OUTPUT).read_text(errors="replace").splitlines()
                if line.startswith("ERROR")
            ]
            if not errors
            else []
        )
        if errors:
            hint = (
                f" (time step {dt:.3g} s = {job.timestep_fraction:g} T_R too large?)"
                if "Lost atoms" in errors[0]
                else ""
            )
            error = _printable(errors[0].removeprefix("ERROR: "))
            return f"LIGGGHTS error: {error}{hint} | log: {tail}"
        if returncode != 0:
            return f"LIGGGHTS exited with code {returncode}: {tail}"
        unstable = re.search(r"^demcal-unstable (\w+) (\S+)", log, re.M)
        if unstable:
            return (
                f"unstable during {unstable.group(1)}: kinetic energy {unstable.group(2)} J "
                f"exceeds {BLOWUP_FACTOR:g} times the potential energy of the material; "
                f"time step {dt:.3g} s ({job.timestep_fraction:g} T_R) too large "
                f"for this stiffness?"
            )
        if not done:
            return f"LIGGGHTS stopped before the end of its script: {tail}"
        return ""

    @staticmethod
    def _state(
        case: LiggghtsCase, log: str, workdir: Path
    ) -> tuple[dict[str, float], dict[str, np.ndarray]]:
        """Measurements and arrays from the dumps (read, checked finite, handed to the case)."""
        rest = dict(re.findall(r"^demcal-rest (\w+) ([01])", log, re.M))
        measurements: dict[str, float] = {}
        arrays: dict[str, np.ndarray] = {}
        for stage, name in case.dumps.items():
            try:
                data = read_dump(workdir / name)
            except (OSError, ValueError, StopIteration) as exc:
                raise SimulationFailed(f"LIGGGHTS {stage} dump {name} unreadable: {exc}") from None
            if not all(np.isfinite(data[k]).all() for k in ("x", "y", "z", "radius") if k in data):
                raise SimulationFailed(f"unstable: non-finite particle positions after {stage}")
            stage_measurements, stage_arrays = case.collect(stage, data, rest.get(stage) == "1")
            measurements.update(stage_measurements)
            arrays.update(stage_arrays)
        return measurements, arrays
