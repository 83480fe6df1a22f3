"""Child process of the LAMMPS engine: runs one scene driver, writes its result files.

Usage: ``python -m demcal.engines.lammps_worker JOB.json``, the job file
holding ``{"driver": "module:name", "job": {SimulationJob fields}}``: the
worker imports the driver from that path and runs it on the job. Writes
``lammps-result.json`` (status, reason, measurements, cost) and, if the driver
returned particle arrays, ``lammps-state.npz`` beside the job file. A driver
error becomes a failed result with the error text; a crash of LAMMPS itself
kills this process, which the parent records.
"""

from __future__ import annotations

import pkgutil
import sys
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from demcal.engines.base import RunMonitor, RunResult, SimulationJob
from demcal.engines.lammps import RESULT_FILE, STATE_FILE, preload_mpi
from demcal.errors import SimulationFailed
from demcal.results.records import Status
from demcal.results.storage import read_json, write_json


def _lammps_message(exc: Exception) -> str:
    """LAMMPS errors arrive as 'ERROR: text (src/file.cpp:NNN)': keep the text."""
    text = str(exc).strip().removeprefix("ERROR: ")
    return text.split(" (src/")[0]


def main(job_path: str) -> int:
    job_file = Path(job_path)
    record = read_json(job_file, "LAMMPS job file")
    job = SimulationJob(**record["job"])
    monitor = RunMonitor(job)
    start = time.process_time()
    driver: Callable[[SimulationJob, RunMonitor], RunResult] = pkgutil.resolve_name(
        record["driver"]
    )
    preload_mpi()
    result_record: dict[str, Any]
    try:
        result = driver(job, monitor)
    except SimulationFailed as exc:
        result_record = {"status": Status.FAILED, "reason": str(exc)}
    except Exception as exc:  # LAMMPS raises plain Exception("ERROR: ...")
        traceback.print_exc()
        result_record = {"status": Status.FAILED, "reason": f"LAMMPS error: {_lammps_message(exc)}"}
    else:
        if result.arrays:
            # the names become savez keywords, typed as its options: no array is "allow_pickle"
            arrays: dict[str, Any] = result.arrays
            np.savez(job_file.parent / STATE_FILE, **arrays)
        result_record = {
            "status": result.status,
            "reason": result.reason,
            "measurements": result.measurements,
            "cost": result.cost,
        }
    result_record.setdefault("cost", {})["worker_cpu_s"] = time.process_time() - start
    write_json(job_file.parent / RESULT_FILE, result_record)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
