"""The small interface every simulator sits behind.

An engine runs one scene replicate: given the parameters, scene settings and
a seed, and the scene's driver for this engine (what the engine runs: an
analytic model, the function that issues a scene's LAMMPS commands, ...), it
streams progress and early response estimates to ``partial.csv``, polls the
STOP file between chunks of work and ends with a ``RunResult`` whose status
is ``ok``, ``terminated`` (stopped on request) or ``failed`` (with the
reason). Responses are either measured by the engine directly
(``measurements``) or computed later by the scene from the saved particle
state (``arrays``). Engines never import scenes: the caller looks the driver
up (``Scene.driver(engine.name)``) and hands it over.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from demcal.files import PartialWriter

OK, TERMINATED, FAILED = "ok", "terminated", "failed"


@dataclass
class SimulationJob:
    """Everything one simulation needs; JSON-serialisable so it can cross a process boundary."""

    scene: str
    parameters: dict[str, float]
    settings: dict
    seed: int
    responses: list[str]
    timestep_fraction: float
    workdir: str
    stop_file: str
    attempt: int = 0  # 0 for the first run of an evaluation, then 1, 2, ... for retries

    @property
    def partial_file(self) -> Path:
        return Path(self.workdir) / "partial.csv"


@dataclass
class RunResult:
    """Outcome of one simulation. ``cost`` holds wall_s, cpu_s and engine figures (steps, ...)."""

    status: str
    reason: str = ""
    measurements: dict[str, float] = field(default_factory=dict)
    arrays: dict[str, np.ndarray] = field(default_factory=dict)
    cost: dict[str, float] = field(default_factory=dict)


def signal_name(returncode: int) -> str:
    """Name of the signal that ended a process with a negative ``returncode`` (SIGSEGV, ...)."""
    try:
        return signal.Signals(-returncode).name
    except ValueError:
        return f"signal {-returncode}"


#: Seconds a simulator process group gets to end after SIGTERM before SIGKILL.
GRACE_SECONDS = 10.0


def stop_process_group(proc: subprocess.Popen) -> None:
    """End a simulator started in its own session: SIGTERM, then SIGKILL after the grace time."""
    os.killpg(proc.pid, signal.SIGTERM)
    try:
        proc.wait(GRACE_SECONDS)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()


class RunMonitor:
    """What a running simulation uses to report progress and learn of a stop request."""

    def __init__(self, job: SimulationJob, clock=time.monotonic):
        self.stop_file = Path(job.stop_file)
        self.partial = PartialWriter(job.partial_file, clock)

    def stop_requested(self) -> bool:
        return self.stop_file.exists()

    def progress(self, fraction: float, stage: str, estimates: dict[str, float] | None = None,
                 final: bool = False) -> None:
        """Report progress; ``estimates`` of responses are ``final`` once they cannot change."""
        self.partial.write(min(max(fraction, 0.0), 1.0), stage, estimates, final)


class Engine(ABC):
    """A simulator. Subclasses set ``name`` and implement ``run``.

    ``check`` receives the study's scenes as objects: an engine reads what
    they declare (``parameters``, ``driver(name)``) and never imports them.
    A retry of a failed evaluation runs in a fresh run directory (the
    daemon deletes the evaluation's scene directories first): an engine
    keeps nothing there across attempts.
    """

    name: str = ""

    def __init__(self, settings: dict | None = None):
        self.settings = dict(settings or {})

    def check(self, scenes: list) -> None:  # noqa: B027  (optional: most engines need no check)
        """Raise ConfigError if this engine cannot run these scenes here (binary missing, ...)."""

    def version(self) -> str:
        return "unknown"

    @abstractmethod
    def run(self, job: SimulationJob, monitor: RunMonitor,
            driver: Callable | None) -> RunResult:
        """Run one simulation to its end, a stop request, or a failure with reason.

        ``driver`` is the scene's driver for this engine (``Scene.driver``),
        None if the scene has none.
        """
