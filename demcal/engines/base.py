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

import ctypes
import os
import signal
import subprocess
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from demcal.results.layout import PARTIAL_FILE
from demcal.results.storage import PartialWriter


@dataclass
class SimulationJob:
    """Everything one simulation needs; JSON-serialisable so it can cross a process boundary."""

    scene: str
    parameters: dict[str, float]
    settings: dict[str, Any]
    seed: int
    responses: list[str]
    timestep_fraction: float
    workdir: str
    stop_file: str
    attempt: int = 0  # 0 for the first run of an evaluation, then 1, 2, ... for retries

    @property
    def partial_file(self) -> Path:
        return Path(self.workdir) / PARTIAL_FILE


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


def stop_process_group(proc: subprocess.Popen[bytes]) -> None:
    """End a simulator started in its own session: SIGTERM, then SIGKILL after the grace time."""
    os.killpg(proc.pid, signal.SIGTERM)
    try:
        proc.wait(GRACE_SECONDS)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()


#: prctl option that makes a process the reaper of its orphaned descendants (linux/prctl.h)
PR_SET_CHILD_SUBREAPER = 36


def adopt_orphans() -> None:
    """Become the reaper of this process's orphaned descendants (Linux), so that a simulator's
    process that detaches (``setsid``, a double fork) is re-parented here, not to init, and
    ``descendants`` still finds it for ``end_processes``. Elsewhere nothing changes."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)
    except (OSError, AttributeError):
        pass


def descendants(pid: int) -> set[int]:
    """The live processes below ``pid`` in the process tree (from /proc; empty elsewhere)."""
    children: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            state, parent = stat.read_text().rsplit(")", 1)[1].split()[:2]
        except (OSError, ValueError):
            continue  # ended meanwhile
        if state != "Z":
            children.setdefault(int(parent), []).append(int(stat.parent.name))
    found, queue = set(), [pid]
    while queue:
        for child in children.get(queue.pop(), []):
            found.add(child)
            queue.append(child)
    return found


def end_processes(pids: set[int], grace: float = GRACE_SECONDS) -> None:
    """SIGTERM ``pids``, SIGKILL those still alive after ``grace`` seconds; reap our children."""

    def signal_all(signum: int) -> None:
        for pid in pids:
            try:
                os.kill(pid, signum)
            except ProcessLookupError:
                pass

    def reap() -> None:  # our children among them (adopted orphans) would stay zombies
        for pid in pids:
            try:
                os.waitpid(pid, os.WNOHANG)
            except ChildProcessError:
                pass  # not our child: its own parent reaps it

    signal_all(signal.SIGTERM)
    deadline = time.monotonic() + grace
    while pids & descendants(os.getpid()) and time.monotonic() < deadline:
        time.sleep(0.1)
    if pids & descendants(os.getpid()):
        signal_all(signal.SIGKILL)
        time.sleep(0.1)
    reap()


class RunMonitor:
    """What a running simulation uses to report progress and learn of a stop request."""

    def __init__(self, job: SimulationJob, clock: Callable[[], float] = time.monotonic):
        self.stop_file = Path(job.stop_file)
        self.partial = PartialWriter(job.partial_file, clock)

    def stop_requested(self) -> bool:
        return self.stop_file.exists()

    def progress(
        self,
        fraction: float,
        stage: str,
        estimates: dict[str, float] | None = None,
        final: bool = False,
    ) -> None:
        """Report progress; ``estimates`` of responses are ``final`` once they cannot change."""
        self.partial.write(min(max(fraction, 0.0), 1.0), stage, estimates, final)


class DeclaredScene(Protocol):
    """What an engine reads of a scene (``demcal.scenes.base.Scene``), which it never imports."""

    @property
    def name(self) -> str: ...

    @property
    def parameters(self) -> tuple[str, ...]: ...

    def driver(self, engine: str) -> Callable[..., Any] | None: ...


class Engine(ABC):
    """A simulator. Subclasses set ``name`` and implement ``run``.

    ``check`` receives the study's scenes as objects: an engine reads what
    they declare (``parameters``, ``driver(name)``) and never imports them.
    A retry of a failed evaluation runs in a fresh run directory (the
    daemon deletes the evaluation's scene directories first): an engine
    keeps nothing there across attempts.
    """

    name: str = ""
    #: Whether it integrates in time steps (a fraction of the Rayleigh time); the analytic
    #: engine does not.
    steps_in_time: bool = True

    def __init__(self, settings: dict[str, Any] | None = None):
        self.settings = dict(settings or {})

    # optional, so not abstract: most engines need no check
    def check(self, scenes: Sequence[DeclaredScene]) -> None:  # noqa: B027
        """Raise ConfigError if this engine cannot run these scenes here (binary missing, ...)."""

    def gives_estimates(self) -> bool:
        """Whether its simulations report early estimates of their responses while they run,
        which early termination judges (Samuelsson 2023, sec. 3.6.1)."""
        return True

    def version(self) -> str:
        return "unknown"

    #: Material parameters its drivers do not model: a study must leave them at their
    #: catalogue default.
    UNMODELLED_PARAMETERS: tuple[str, ...] = ()

    #: Settings that never change an ok run's responses (limits, reporting), left out of
    #: :meth:`outcome`.
    INERT_SETTINGS: tuple[str, ...] = ("timeout",)

    def outcome(self) -> dict[str, Any]:
        """What of this engine decides a simulation's responses, beyond the parameters,
        settings, seed and time step: its name, version and settings. Two simulations are
        interchangeable data only if these agree (``Study.simulator``)."""
        return {
            "engine": self.name,
            "version": self.version(),
            "settings": {k: v for k, v in self.settings.items() if k not in self.INERT_SETTINGS},
        }

    def reuse_problem(self) -> str | None:
        """Why demcal cannot tell this engine's simulations apart from another simulator's
        (they are then never reused); None when it can."""
        return None

    @abstractmethod
    def run(
        self, job: SimulationJob, monitor: RunMonitor, driver: Callable[..., Any] | None
    ) -> RunResult:
        """Run one simulation to its end, a stop request, or a failure with reason.

        ``driver`` is the scene's driver for this engine (``Scene.driver``),
        None if the scene has none.
        """
