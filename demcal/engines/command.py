"""Command engine: any simulator run through a user-given command template.

The template (engine setting ``command``) is split with ``shlex`` and each
word formatted with the placeholders ``{input}`` (the input file, copied into
the run directory), ``{workdir}``, ``{seed}``, ``{timestep_fraction}``,
``{scene}`` and every parameter name; it is never run through a shell, so no
value can inject a command. The simulator writes ``responses_file`` (a JSON
object response -> value, relative to the run directory) and may append
``partial_file`` (CSV with columns progress,response,value; response and
value may be empty) while it runs; demcal reads on from where its last poll
stopped and keeps the estimates of the job's responses. Either file beyond
its size limit fails the run. A STOP request terminates the process group and
records the run as terminated.
"""

from __future__ import annotations

import json
import math
import os
import shlex
import shutil
import string
import subprocess
import time
from collections.abc import Callable, Sequence
from pathlib import Path, PurePosixPath
from typing import Any

from demcal.engines.base import (
    DeclaredScene,
    Engine,
    RunMonitor,
    RunResult,
    SimulationJob,
    adopt_orphans,
    descendants,
    end_processes,
    signal_name,
    stop_process_group,
)
from demcal.errors import ConfigError, SimulationFailed
from demcal.results.layout import PARTIAL_FILE, RESPONSES_FILE, SIMULATION_FILE, STATE_FILE
from demcal.results.records import Status
from demcal.results.storage import GrowingCsv, file_sha256, log_tail, read_json

POLL_SECONDS = 0.5
#: Largest responses file read (a JSON object of a few numbers) and partial file followed.
RESPONSES_FILE_BYTES, PARTIAL_FILE_BYTES = 2**20, 16 * 2**20
LOG_FILE = "command.log"
FIXED_PLACEHOLDERS = ("input", "workdir", "seed", "timestep_fraction", "scene")
#: Files demcal itself keeps in a run directory; a simulator's file may not take their names.
DEMCAL_RUN_FILES = (SIMULATION_FILE, RESPONSES_FILE, PARTIAL_FILE, STATE_FILE, LOG_FILE)
#: Engine settings naming a file the engine deletes or reads inside the run directory.
RUN_DIRECTORY_FILES = ("responses_file", "partial_file")


def run_directory_file(name: str, where: str) -> PurePosixPath:
    """A simulator's file name, checked to stay inside the run directory.

    The engine deletes ``responses_file`` before each run, so a path that
    leaves the run directory (absolute, or with ``..``) could delete any
    file; such paths are refused when the study is loaded.
    """
    path = PurePosixPath(name)
    if not name.strip() or path.is_absolute() or ".." in path.parts or name.endswith("/"):
        raise ConfigError(
            f"{where}: {name!r} must be a file name relative to the simulation's "
            f"run directory, without '..' (e.g. responses.json in a subfolder: "
            f"out/responses.json)"
        )
    if len(path.parts) == 1 and name in DEMCAL_RUN_FILES:
        raise ConfigError(
            f"{where}: {name!r} is a file demcal keeps in the run directory; "
            f"choose another name (taken: {', '.join(DEMCAL_RUN_FILES)})"
        )
    return path


def placeholders(template: str) -> set[str]:
    """Names of the ``{...}`` fields of a command template."""
    return {
        name
        for word in shlex.split(template)
        for _, name, _, _ in string.Formatter().parse(word)
        if name
    }


def command_words(template: str, fields: dict[str, object]) -> list[str]:
    """The argument vector: shlex words, each formatted with ``fields``.

    An executable given as a relative path (bin/sim) is taken from the
    current directory, where the study was checked, not from the run
    directory the simulator runs in.
    """
    words = [word.format(**fields) for word in shlex.split(template)]
    if "/" in words[0]:
        words[0] = os.path.abspath(words[0])
    return words


def simulator_numbers(values: dict[str, Any], names: list[str], where: str) -> dict[str, float]:
    """The responses ``names`` from a simulator's JSON object, each a finite number (not a boolean).

    Raises SimulationFailed naming the file, the response and what it held instead.
    """
    numbers = {}
    for name in names:
        if name not in values:
            raise SimulationFailed(
                f"simulator responses file {where}: no {name!r} "
                f"(it has: {', '.join(map(str, values)) or 'nothing'})"
            )
        value = values[name]
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            held = "null" if value is None else f"{json.dumps(value)[:60]} ({type(value).__name__})"
            raise SimulationFailed(
                f"simulator responses file {where}: {name!r} is {held}, not a number"
            )
        if not math.isfinite(value):
            raise SimulationFailed(
                f"simulator responses file {where}: {name!r} is {value}, not a finite number"
            )
        numbers[name] = float(value)
    return numbers


def _number(text: str | None) -> float | None:
    """A partial file's field as a number; None if it is missing or not a number."""
    if text is None:
        return None
    try:
        return float(text)
    except ValueError:
        return None


class SimulatorProgress(GrowingCsv):
    """Latest progress, and latest finite estimate of each of ``responses``, from the
    simulator's partial file; more than PARTIAL_FILE_BYTES raises SimulationFailed."""

    def __init__(self, path: Path, name: str, responses: list[str]):
        self.responses = set(responses)
        super().__init__(path, f"partial file {name}", PARTIAL_FILE_BYTES)

    def forget(self) -> None:
        self.progress: float | None = None
        self.estimates: dict[str, float] = {}

    def take(self, row: dict[str | None, str | None]) -> None:
        """``row``: a line's fields by column name, None where the line is short of a field."""
        progress = _number(row.get("progress"))
        if progress is None or not math.isfinite(progress):
            return
        self.progress = progress
        response = row.get("response")
        if response in self.responses:
            value = _number(row["value"])
            if value is not None and math.isfinite(value):
                self.estimates[response] = value


class CommandEngine(Engine):
    name = "command"
    #: the wall-clock limit and the file of early estimates leave an ok run's responses be
    INERT_SETTINGS = ("timeout", "partial_file")

    def __init__(self, settings: dict[str, Any] | None = None):
        super().__init__(settings)
        for key in RUN_DIRECTORY_FILES:
            if key in self.settings:
                run_directory_file(self.settings[key], f"engine.{key}")
        if "input" in self.settings:
            name = Path(self.settings["input"]).name
            if name in DEMCAL_RUN_FILES or name in (
                self.settings.get(k) for k in RUN_DIRECTORY_FILES
            ):
                raise ConfigError(
                    f"engine.input: its name {name!r} is taken in the run "
                    f"directory (demcal's files: {', '.join(DEMCAL_RUN_FILES)}; "
                    f"and the simulator's responses/partial file); rename it"
                )

    def gives_estimates(self) -> bool:
        """Only through ``partial_file``."""
        return "partial_file" in self.settings

    def check(self, scenes: Sequence[DeclaredScene]) -> None:
        template = self.settings["command"]
        try:
            words = shlex.split(template)
        except ValueError as exc:
            raise ConfigError(f"engine.command: cannot split {template!r}: {exc}") from None
        executable = words[0]
        if shutil.which(executable) is None:
            if "/" not in executable:
                raise ConfigError(
                    f"engine.command: executable {executable!r} not found on PATH "
                    f"(is the simulator installed?)"
                )
            path = Path(executable)
            if not path.exists():
                raise ConfigError(f"engine.command: executable {executable!r} not found")
            why = (
                "a directory"
                if path.is_dir()
                else "no execute permission: chmod +x it, "
                "or put its interpreter first in the command"
            )
            raise ConfigError(f"engine.command: {executable!r} is not executable ({why})")
        for word in words:
            try:
                fields = list(string.Formatter().parse(word))
            except ValueError as exc:
                raise ConfigError(
                    f"engine.command: {word!r}: {exc} (write a literal brace as {{{{ or }}}})"
                ) from None
            for _, name, spec, conversion in fields:
                if name is not None and (not name.isidentifier() or spec or conversion):
                    raise ConfigError(
                        f"engine.command: {word!r}: placeholders are plain names "
                        f"such as {{seed}} or {{sliding_friction_pp}}, without "
                        f"formats, conversions, indices or empty braces"
                    )
        known = set(FIXED_PLACEHOLDERS) | {p for s in scenes for p in s.parameters}
        named = placeholders(template)
        unknown = sorted(named - known)
        if unknown:
            raise ConfigError(
                f"engine.command: unknown placeholder {{{unknown[0]}}}; "
                f"allowed: {', '.join(sorted(known))}"
            )
        if "input" in named and "input" not in self.settings:
            raise ConfigError(
                "engine.command: {input} needs engine.input, the file that is "
                "copied into the run directory and named by {input}; give "
                "engine.input or take {input} out of the command"
            )
        if "input" in self.settings and not Path(self.settings["input"]).is_file():
            raise ConfigError(f"engine.input: file {self.settings['input']!r} not found")

    def version(self) -> str:
        """The simulator's version as the study names it (``engine.version``), else its
        executable."""
        named = self.settings.get("version")
        executable = shlex.split(self.settings["command"])[0]
        return f"command: {executable}" + (f" {named}" if named else "")

    def outcome(self) -> dict[str, Any]:
        """What decides the responses: the command, the version the study names, and the
        content of every file the command or ``engine.input`` names (executable, scripts,
        input), so an edited script is another simulator."""
        executable, *arguments = shlex.split(self.settings["command"])
        paths = {word: word for word in [*arguments, self.settings.get("input", "")]}
        paths[executable] = shutil.which(executable) or executable
        files = {
            word: file_sha256(path)
            for word, path in paths.items()
            if word and not placeholders(word) and Path(path).is_file()
        }
        return {**super().outcome(), "files": files}

    def reuse_problem(self) -> str | None:
        if self.settings.get("version"):
            return None
        return (
            "engine.version: name the simulator's version (any text, e.g. 'mysim 2.1'); demcal "
            "cannot tell what a command computes, so it reuses simulations only between studies "
            "that name the same version and run the same command and files"
        )

    def run(
        self, job: SimulationJob, monitor: RunMonitor, driver: Callable[..., Any] | None
    ) -> RunResult:
        """Run the command template; ``driver`` is unused (scenes name none for this engine)."""
        workdir = Path(job.workdir).resolve()
        fields = {
            **job.parameters,
            "workdir": str(workdir),
            "seed": job.seed,
            "timestep_fraction": job.timestep_fraction,
            "scene": job.scene,
        }
        if "input" in self.settings:
            source = Path(self.settings["input"])
            shutil.copy(source, workdir / source.name)
            fields["input"] = source.name
        responses_path = workdir / self.settings["responses_file"]
        if not responses_path.resolve().is_relative_to(workdir):
            return RunResult(
                Status.FAILED,
                f"responses_file {self.settings['responses_file']!r} "
                f"resolves outside the run directory (a symbolic link?); "
                f"nothing was run or deleted",
            )
        responses_path.unlink(missing_ok=True)
        partial = (
            SimulatorProgress(
                workdir / self.settings["partial_file"],
                self.settings["partial_file"],
                job.responses,
            )
            if "partial_file" in self.settings
            else None
        )
        timeout = float(self.settings.get("timeout", float("inf")))
        start, cpu_before = time.monotonic(), os.times()
        adopt_orphans()
        ours_before = descendants(os.getpid())
        with open(workdir / LOG_FILE, "w") as log:
            try:
                proc = subprocess.Popen(
                    command_words(self.settings["command"], fields),
                    cwd=workdir,
                    stdin=subprocess.DEVNULL,
                    stdout=log,
                    stderr=subprocess.STDOUT,
                    start_new_session=True,
                )
            except OSError as exc:
                return RunResult(Status.FAILED, f"cannot start the simulator: {exc}")
            outcome = self._watch(proc, monitor, partial, start, timeout)
        # what the simulator left running (detached with setsid or a double fork) ends with it
        end_processes(descendants(os.getpid()) - ours_before)
        cpu_after = os.times()
        cost = {
            "wall_s": time.monotonic() - start,
            "cpu_s": (cpu_after.children_user - cpu_before.children_user)
            + (cpu_after.children_system - cpu_before.children_system),
        }
        if outcome is not None:
            return RunResult(outcome[0], outcome[1], cost=cost)
        if proc.returncode != 0:
            tail = log_tail(workdir / LOG_FILE)
            how = (
                f"died from {signal_name(proc.returncode)}"
                if proc.returncode < 0
                else f"exited with code {proc.returncode}"
            )
            output = (
                f": {tail} (its output: {LOG_FILE} in the run directory)"
                if tail
                else " (no output)"
            )
            return RunResult(Status.FAILED, f"simulator {how}{output}", cost=cost)
        try:
            values = read_json(responses_path, "simulator responses file", RESPONSES_FILE_BYTES)
            measurements = simulator_numbers(values, job.responses, self.settings["responses_file"])
        except SimulationFailed as exc:
            return RunResult(Status.FAILED, str(exc), cost=cost)
        return RunResult(Status.OK, measurements=measurements, cost=cost)

    @staticmethod
    def _watch(
        proc: subprocess.Popen[bytes],
        monitor: RunMonitor,
        partial: SimulatorProgress | None,
        start: float,
        timeout: float,
    ) -> tuple[str, str] | None:
        """Wait for the process, forwarding progress; stop it on STOP, timeout or a partial
        file beyond its limit."""
        last = None
        while proc.poll() is None:
            if monitor.stop_requested() or time.monotonic() - start > timeout:
                stop_process_group(proc)
                if monitor.stop_requested():
                    return Status.TERMINATED, "stop requested"
                return Status.FAILED, f"simulation exceeded the engine timeout of {timeout:g} s"
            if partial is not None:
                try:
                    partial.read_on()
                except SimulationFailed as exc:
                    stop_process_group(proc)
                    return Status.FAILED, (
                        f"{exc}; the simulator was stopped (a partial file holds "
                        f"progress reports: a row every few seconds, not every step)"
                    )
                reported = (partial.progress, dict(partial.estimates))
                if partial.progress is not None and reported != last:
                    monitor.progress(partial.progress, "run", partial.estimates or None)
                    last = reported
            time.sleep(POLL_SECONDS)
        return None
