"""The records that the results files hold (`demcal.results.layout` says where they live).

One frozen dataclass per file, each with ``to_dict``/``from_dict``, a format
version and ``read``/``write``:

| record | file: what it holds |
|---|---|
| ``PointRecord`` | ``evals/<id>/params.json``: the point and its runs |
| ``LaunchRecord`` | ``evals/<id>/launch.json``: the child Snakemake |
| ``SimulationRecord`` | ``<scene>/rep<r>/simulation.json``: one simulation |
| ``ResponsesRecord`` | ``<scene>/rep<r>/responses.json``: its responses |
| ``ObjectiveRecord`` | ``evals/<id>/objective.json`` and ``evals/<id>/rescored.json`` |
| ``BestRecord`` | ``best.json``: the best point so far |
| ``FinishedRecord`` | ``finished.json``: why the calibration ended |
| ``ReusedRecord`` | ``reused.json``: the archive's simulations it reused |

The objective job writes ``objective.json``; ``rescored.json`` holds a re-score of
the same evaluation after the targets were corrected.

A file written by this version carries ``"format": 1``; older files without
the key still load. A reader that meets a missing, damaged or malformed
file raises ``SimulationFailed`` naming the file and what is wrong, which
the callers record as the evaluation's failure or show as one line.

A ``Status`` is a ``str``: it compares equal to the word read back from a
file (``Status.OK == "ok"``), and JSON, CSV and f-strings write it as that
word.
"""

from __future__ import annotations

import dataclasses
import enum
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar, Self

from demcal.errors import SimulationFailed
from demcal.physics.catalogue import upgrade_parameters
from demcal.results.layout import (
    BEST_FILE,
    CAMPAIGN_FILE,
    FINISHED_FILE,
    LAUNCH_FILE,
    OBJECTIVE_FILE,
    PARAMS_FILE,
    RESPONSES_FILE,
    REUSED_FILE,
    SIMULATION_FILE,
    EvaluationFiles,
)
from demcal.results.storage import read_json, write_json

#: Format of the records this version writes (the ``"format"`` key of every file).
FORMAT = 1


class Status(enum.StrEnum):
    """The status of a simulation or an evaluation, as the results files spell it.

    - ``OK``: ran to the end; its responses (and, for an evaluation, its
      objective) are there.
    - ``FAILED``: ended without a usable result, with the reason. The daemon
      retries a failed evaluation up to the study's retries (unless the
      calibration is being stopped); the optimizer never proposes the point,
      nor a small ball around it, again.
    - ``TERMINATED``: stopped early on request (its STOP file, written by
      early termination or ``demcal stop``). The optimizer keeps the point in
      its distance set only; what the run completed or estimated enters the
      response models.
    - ``PENDING``: handed out and not yet told: launched (or about to be)
      with no readable objective record yet. The optimizer, the evaluations
      table and the figures all use this word.
    """

    OK = "ok"
    FAILED = "failed"
    TERMINATED = "terminated"
    PENDING = "pending"


#: The fidelity level of a study's own settings (``fidelities:`` adds cheaper ones): the level
#: of a record that names none.
FINE = "fine"


#: The statuses of a simulation or an evaluation that has ended (all but PENDING): what the
#: optimizer is told and what the archive keeps.
ENDED = (Status.OK, Status.FAILED, Status.TERMINATED)


def status_of(value: Any, where: str) -> Status:
    """The Status spelled ``value``; anything else is a SimulationFailed naming ``where``."""
    try:
        return Status(value)
    except ValueError:
        words = ", ".join(s.value for s in Status)
        raise SimulationFailed(f"{where}: status {value!r} is not one of {words}") from None


@dataclass(frozen=True)
class Record:
    """Base of the records: dict conversion, format check, reading and writing by file."""

    #: the file's usual name, for messages
    FILE: ClassVar[str] = ""

    def to_dict(self) -> dict[str, Any]:
        """The record as the file holds it: its fields (None-valued optional ones left out)."""
        out: dict[str, Any] = {"format": FORMAT}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if value is None and f.metadata.get("optional"):
                continue
            out[f.name] = value
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any], where: str = "") -> Self:
        """The record of a file's dict; ``where`` names the file in errors."""
        where = where or cls.FILE
        if not isinstance(data, dict):
            raise SimulationFailed(f"{where}: not a JSON object")
        version = data.get("format", FORMAT)
        if not isinstance(version, int) or isinstance(version, bool):
            raise SimulationFailed(f"{where}: format {version!r} is not a version number")
        if version > FORMAT:
            raise SimulationFailed(
                f"{where}: format {version!r} was written by a newer demcal (this one reads "
                f"format {FORMAT} and older)"
            )
        try:
            return cls._from_dict(data, where)
        except (KeyError, TypeError, ValueError) as exc:
            raise SimulationFailed(f"{where}: malformed ({type(exc).__name__}: {exc})") from None

    @classmethod
    def _from_dict(cls, data: dict[str, Any], where: str) -> Self:
        """The record of the fields it knows, each checked against its annotation."""
        hints = typing.get_type_hints(cls)
        values = {f.name: data[f.name] for f in dataclasses.fields(cls) if f.name in data}
        for name, value in values.items():
            if not _is_a(value, hints[name]):
                raise SimulationFailed(f"{where}: {name} is {value!r}, not {_shown(hints[name])}")
        return cls(**values)

    @classmethod
    def read(cls, path: Path) -> Self:
        """The record in ``path``; a missing or damaged file is a SimulationFailed naming it."""
        return cls.from_dict(read_json(path, cls.FILE), str(path))

    @classmethod
    def read_if_any(cls, path: Path) -> Self | None:
        """The record in ``path``, or None if there is none yet (or it is unreadable)."""
        try:
            return cls.read(path)
        except SimulationFailed:
            return None

    def write(self, path: Path) -> None:
        """Write the record atomically (non-finite numbers become null)."""
        write_json(path, self.to_dict())


def _is_a(value: Any, hint: Any) -> bool:
    """Whether a JSON value fits a field's annotation: its container, number, text or
    true/false kind, or None where the field is optional (elements are not checked)."""
    if isinstance(hint, types.UnionType):
        return any(_is_a(value, arm) for arm in typing.get_args(hint))
    kind = typing.get_origin(hint) or hint
    if kind is type(None):
        return value is None
    if kind is float:
        return isinstance(value, int | float) and not isinstance(value, bool)
    if kind is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if kind is Status:  # a word, checked against the words by status_of
        return isinstance(value, str)
    return isinstance(value, kind)


def _shown(hint: Any) -> str:
    """A field's annotation in words for a message."""
    words = {dict: "an object", list: "a list", str: "text", float: "a number", int: "an integer"}
    words |= {bool: "true or false", type(None): "null", Status: "a status word"}
    arms = typing.get_args(hint) if isinstance(hint, types.UnionType) else (hint,)
    return " or ".join(words.get(typing.get_origin(arm) or arm, str(arm)) for arm in arms)


def _optional(default: Any = None) -> Any:
    """A field left out of the file while it is None."""
    return field(default=default, metadata={"optional": True})


@dataclass(frozen=True)
class CampaignRecord(Record):
    """``campaign.json``: a sampling campaign's design (``demcal sample``).

    ``design`` names the design (an entry of the optimizer's DESIGNS), ``seed`` the stream it
    was drawn from, ``unit_points`` its points in the unit box of the free parameters, in
    order (evaluation ``e0000`` is the first); an extension appends to them.
    """

    FILE: ClassVar[str] = CAMPAIGN_FILE

    design: str
    seed: int
    unit_points: list[list[float]]
    #: the fidelity levels each point runs at, in order: point k at level j is evaluation
    #: ``k * len(fidelities) + j``
    fidelities: list[str] = field(default_factory=lambda: [FINE])


@dataclass(frozen=True)
class PointRecord(Record):
    """``params.json``: the free-parameter values of a point and how often it was run.

    ``parameters`` is kept as written (a hand-written file may hold text);
    the simulate job checks it against the study. ``staged``: its first
    simulations run before the others (a staged study's evaluation that early
    termination may stop; ``demcal.jobs.steps.staged_inputs``). ``fidelity``: the level it
    runs at (``Study.level``); None, the study's own settings (:data:`FINE`).
    """

    FILE: ClassVar[str] = PARAMS_FILE

    parameters: dict[str, Any]
    attempt: int = 0
    previous_failures: list[str] = field(default_factory=list)
    in_initial_design: bool = False
    proposed_by: str | None = _optional()
    staged: bool = False
    fidelity: str | None = _optional()

    @property
    def level(self) -> str:
        """The fidelity level the point runs at (:data:`FINE` unless it names another)."""
        return self.fidelity or FINE

    @classmethod
    def _from_dict(cls, data: dict[str, Any], where: str) -> Self:
        if not isinstance(data.get("parameters"), dict):
            raise SimulationFailed(f"{where} has no 'parameters' object")
        attempt = data.get("attempt", 0)
        if not isinstance(attempt, int) or isinstance(attempt, bool) or attempt < 0:
            raise SimulationFailed(f"{where}: attempt {attempt!r} is not a count")
        failures = data.get("previous_failures", [])
        if not isinstance(failures, list) or not all(isinstance(f, str) for f in failures):
            raise SimulationFailed(f"{where}: previous_failures {failures!r} is not a list of text")
        proposed_by = data.get("proposed_by")
        if proposed_by is not None and not isinstance(proposed_by, str):
            raise SimulationFailed(f"{where}: proposed_by {proposed_by!r} is not text")
        fidelity = data.get("fidelity")
        if fidelity is not None and not isinstance(fidelity, str):
            raise SimulationFailed(f"{where}: fidelity {fidelity!r} is not a level's name")
        return cls(
            data["parameters"],
            attempt,
            list(failures),
            bool(data.get("in_initial_design", False)),
            proposed_by,
            data.get("staged") is True,
            fidelity,
        )

    def retried(self, reason: str | None) -> PointRecord:
        """The point for its next run (new seeds), with the reason of the failed one if given."""
        failures = self.previous_failures + ([] if reason is None else [reason])
        return dataclasses.replace(self, attempt=self.attempt + 1, previous_failures=failures)


@dataclass(frozen=True)
class LaunchRecord(Record):
    """``launch.json``: pid and start time (Unix s) of the evaluation's child Snakemake."""

    FILE: ClassVar[str] = LAUNCH_FILE

    pid: int
    started_at: float


#: How the reason of a simulation that never started begins (its evaluation was stopped, or a
#: simulation it waited for did not end ok: ``demcal.jobs.steps.not_started``).
NOT_STARTED = "not started: "


@dataclass(frozen=True)
class SimulationRecord(Record):
    """``simulation.json``: one scene replicate as the simulate job ran it.

    ``parameters`` are the resolved material parameters (SI units) the engine
    was given; ``measurements`` the responses the engine measured itself;
    ``cost`` its ``cpu_s``/``wall_s``; ``state_file`` the saved particle
    state (``state.npz``) when responses are computed from it. A simulation
    that never started is terminated with a reason beginning ``NOT_STARTED``.
    """

    FILE: ClassVar[str] = SIMULATION_FILE

    evaluation: str
    scene: str
    replicate: int
    engine: str
    engine_version: str
    settings: dict[str, Any]
    timestep_fraction: float
    responses_needed: list[str]
    started_at: float
    status: Status
    reason: str = ""
    seed: int | None = None
    attempt: int | None = None
    parameters: dict[str, float] = field(default_factory=dict)
    measurements: dict[str, float] = field(default_factory=dict)
    cost: dict[str, float] = field(default_factory=dict)
    ended_at: float | None = None
    state_file: str | None = _optional()
    #: what simulated it (``Study.simulator``); {} in files of demcal before it was recorded
    simulator: dict[str, Any] = field(default_factory=dict)
    #: the fidelity level it ran at; None: the study's own settings (:data:`FINE`)
    fidelity: str | None = _optional()

    @property
    def ran(self) -> bool:
        """Whether the engine ran (an archive records only simulations that did)."""
        return not (self.status == Status.TERMINATED and self.reason.startswith(NOT_STARTED))

    @classmethod
    def _from_dict(cls, data: dict[str, Any], where: str) -> Self:
        record = super()._from_dict(data, where)
        return dataclasses.replace(
            record,
            status=status_of(record.status, where),
            parameters=upgrade_parameters(record.parameters),
        )


@dataclass(frozen=True)
class ResponsesRecord(Record):
    """``responses.json``: the responses of one simulation, or why there are none."""

    FILE: ClassVar[str] = RESPONSES_FILE

    status: Status
    reason: str = ""
    responses: dict[str, float] = field(default_factory=dict)
    evaluation: str | None = None
    scene: str | None = None
    replicate: int | None = None
    seed: int | None = None
    cost: dict[str, float] | None = None

    @classmethod
    def _from_dict(cls, data: dict[str, Any], where: str) -> Self:
        record = super()._from_dict(data, where)
        return dataclasses.replace(
            record, status=status_of(record.status, where), responses=record.responses or {}
        )


@dataclass(frozen=True)
class ObjectiveRecord(Record):
    """``objective.json`` (or ``rescored.json``): the outcome of one evaluation.

    ``responses`` are the replicate means, ``replicates`` every replicate's
    value and ``spread`` their sample sd, each keyed ``scene.response``;
    ``objective`` is eq. 3.3 of the means (Samuelsson 2023) in the study's
    form plus ``timestep_cost`` (Rackl & Hanley 2017, eq. 10), both from
    the study's ``ResponseObjective``. ``scored_with`` names the version of
    that objective (``ResponseObjective.version``; None in files written
    before format 1): the targets themselves live in the frozen study only.
    ``cost`` holds ``cpu_s`` and ``simulation_wall_s``.
    """

    FILE: ClassVar[str] = OBJECTIVE_FILE

    evaluation: str
    status: Status
    reason: str = ""
    parameters: dict[str, Any] = field(default_factory=dict)
    cost: dict[str, float] = field(default_factory=dict)
    objective: float | None = _optional()
    timestep_cost: float | None = _optional()
    responses: dict[str, float] = field(default_factory=dict)
    replicates: dict[str, list[float]] = field(default_factory=dict)
    spread: dict[str, float] = field(default_factory=dict)
    relative_errors: dict[str, float] = field(default_factory=dict)
    scored_with: str | None = _optional()

    @classmethod
    def _from_dict(cls, data: dict[str, Any], where: str) -> Self:
        record = super()._from_dict(data, where)
        record = dataclasses.replace(record, status=status_of(record.status, where))
        if record.ok and record.objective is None:
            raise SimulationFailed(f"{where}: status ok without an objective")
        return record

    @property
    def ok(self) -> bool:
        return self.status == Status.OK

    @classmethod
    def read_latest(
        cls, files: EvaluationFiles, job: ObjectiveRecord | None = None
    ) -> ObjectiveRecord:
        """The evaluation's outcome as it stands: its re-score (``files.rescored``) if there is
        one, else what its objective job wrote (``files.objective``; ``job`` when the caller
        has read it already)."""
        if files.rescored.exists():
            return cls.read(files.rescored)
        return job if job is not None else cls.read(files.objective)


@dataclass(frozen=True)
class BestRecord(Record):
    """``best.json``: the best point so far and why it is best, in the study's units.

    ``predicted_responses``: ``{key: {"mean", "sd"}}`` of the response models
    there; ``on_bounds``: parameters that lie on a bound, and which;
    ``confirmation``: the re-simulations of the point, when asked for. With
    ``reuse: archive``: ``reused`` is true when the point was taken from the
    archive (``evaluation`` is then the ``study/evaluation`` that simulated it),
    and ``evaluations`` counts the ``new`` evaluations and the ``reused`` points (and, with
    ``reuse: neighbours``, the ``neighbours`` points of neighbouring materials).
    """

    FILE: ClassVar[str] = BEST_FILE

    evaluation: str
    parameters: dict[str, float]
    objective: float
    stop_reason: str | None = None
    units: dict[str, str] = field(default_factory=dict)
    predicted_objective: float | None = None
    chosen_by: str | None = None
    responses: dict[str, float] = field(default_factory=dict)
    targets: dict[str, float] = field(default_factory=dict)
    relative_errors: dict[str, float] = field(default_factory=dict)
    predicted_responses: dict[str, dict[str, float]] = field(default_factory=dict)
    target_spreads: dict[str, float | None] = field(default_factory=dict)
    on_bounds: dict[str, str] = field(default_factory=dict)
    confirmation: dict[str, Any] | None = _optional()
    reused: bool | None = _optional()
    evaluations: dict[str, int] | None = _optional()
    #: ``{"evaluation", "objective"}`` of the evaluated point whose own runs scored lowest,
    #: when it is not the answer (``demcal.optimizer.best.lowest_run``)
    lowest_run: dict[str, Any] | None = _optional()


@dataclass(frozen=True)
class FinishedRecord(Record):
    """``finished.json``: written only once the calibration has ended, with its reason and
    the count of evaluations per status."""

    FILE: ClassVar[str] = FINISHED_FILE

    reason: str
    ended_at: float | None = None
    evaluations: dict[str, int] = field(default_factory=dict)
    #: points taken from the archive (``reuse: archive``), not among ``evaluations``
    reused: int | None = _optional()
    #: points of neighbouring materials taken from the archive (``reuse: neighbours``), not
    #: among ``reused``
    neighbours: int | None = _optional()

    def count(self, status: Status) -> int:
        return int(self.evaluations.get(status, 0))


@dataclass(frozen=True)
class ReusedRecord(Record):
    """``reused.json``: the archive's simulations a study took as data when it started
    (``reuse: archive``), grouped into points; written once, before anything runs.

    Each point is ``{"source", "parameters", "replicates", "simulations"}``: the
    ``study/evaluation`` that simulated it (several joined by ``+``), its free values, each
    targeted response's final values keyed ``scene.response``, and per archived simulation
    its archive ``id``, ``study``, ``evaluation``, ``scene``, ``replicate`` and ``seed``; a
    point of a cheaper level names it (``fidelity``), one of a neighbouring material its
    values of the fixed parameters that differ from the study's (``material``).
    ``archive`` is the archive's URL as shown (without a password).
    """

    FILE: ClassVar[str] = REUSED_FILE

    archive: str
    points: list[dict[str, Any]] = field(default_factory=list)

    @property
    def seeds(self) -> frozenset[int]:
        """The seeds of the reused simulations (new simulations never repeat them)."""
        return frozenset(
            s["seed"] for point in self.points for s in point["simulations"] if s["seed"]
        )
