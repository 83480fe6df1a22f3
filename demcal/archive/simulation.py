"""One archived simulation, and how it is read from the results files of a study.

`from_results` builds the record of one scene replicate from its ``simulation.json``
and ``responses.json`` (and, for a stopped run, the last estimates in its ``partial.csv``);
the archive job and ``demcal archive import`` both use it, so a simulation recorded by its
job and imported later has the same `ArchivedSimulation.key` and is stored once.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from demcal.errors import SimulationFailed
from demcal.physics.catalogue import CATALOG
from demcal.results.layout import ReplicateFiles
from demcal.results.records import FINE, ResponsesRecord, SimulationRecord, Status
from demcal.results.storage import LatestReports
from demcal.study.model import Study, demcal_version

#: Scene settings that describe the particle-size distribution (Samuelsson 2023; Richter &
#: Will 2021 vary d50 and sigma_ln): kept apart in each record as its ``psd``.
PSD_SETTINGS = ("d50", "sigma_ln", "psd_truncation")


def digest(value: object) -> str:
    """sha256 of a JSON value in one canonical spelling (sorted keys, no spaces)."""
    text = json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()


@dataclass(frozen=True)
class Quantity:
    """A parameter or response value with its unit."""

    value: float
    unit: str


@dataclass(frozen=True)
class ArchivedSimulation:
    """A simulation as the archive keeps it.

    ``parameters`` are every material parameter the engine was given and every variable scene
    setting it ran with (d50, sigma_ln: those a study may make free), in SI units; ``free``
    the names among them that the study varied; ``simulator`` the digest of what simulated it
    (``Study.simulator``: engine, version, engine settings, the scene's script; "" for a run
    of a demcal that did not record it, which no study reuses); ``fidelity`` the study's level
    it ran at and ``fine_level`` the digest of that study's fine level of the scene
    (``Study.fine_level_view``; "" where unknown); ``responses`` the final values
    of a run
    that ended ``ok``, or the last estimates of a ``terminated`` one (``final`` says which
    of those could no longer change); a ``failed`` run has none. ``cost`` is the engine's
    own figures (``cpu_s``, ``wall_s``, ``particle_steps``, ...). ``id`` is the archive's
    row number once stored (None before).
    """

    study: str
    evaluation: str
    scene: str
    replicate: int
    engine: str
    engine_version: str
    settings: dict[str, Any]
    timestep_fraction: float
    status: Status
    reason: str = ""
    attempt: int | None = None
    seed: int | None = None
    parameters: dict[str, Quantity] = field(default_factory=dict)
    free: frozenset[str] = frozenset()
    psd: dict[str, Quantity] = field(default_factory=dict)
    responses: dict[str, Quantity] = field(default_factory=dict)
    final: dict[str, bool] = field(default_factory=dict)
    cost: dict[str, Any] = field(default_factory=dict)
    started_at: float | None = None
    ended_at: float | None = None
    demcal_version: str = ""
    source: str = "job"
    simulator: str = ""
    fidelity: str = FINE
    fine_level: str = ""
    id: int | None = None
    recorded_at: float | None = None

    @property
    def provenance(self) -> dict[str, Any]:
        """What makes the simulation this one: study, evaluation, scene, replicate, attempt
        and seed, and what the engine ran (the same run again is the same simulation). The
        simulator is left out where unknown, so records stored before it was kept keep
        their keys."""
        return ({"simulator": self.simulator} if self.simulator else {}) | {
            "study": self.study,
            "evaluation": self.evaluation,
            "scene": self.scene,
            "replicate": self.replicate,
            "attempt": self.attempt,
            "seed": self.seed,
            "engine": self.engine,
            "engine_version": self.engine_version,
            "settings": self.settings,
            "timestep_fraction": self.timestep_fraction,
            "parameters": {
                name: q.value for name, q in self.parameters.items() if name not in self.settings
            },
        }

    @property
    def key(self) -> str:
        """The archive's unique key of the simulation: the digest of its provenance."""
        return digest(self.provenance)

    @property
    def settings_hash(self) -> str:
        """The digest of the settings that are not kept as parameters: what a compatible
        simulation shares exactly (``Archive.compatible``)."""
        return digest({n: v for n, v in self.settings.items() if n not in self.parameters})

    def values(self, names: list[str]) -> list[float]:
        """The values of the named parameters, in that order (a model's inputs)."""
        return [self.parameters[name].value for name in names]


def partial_estimates(partial_csv: Path) -> dict[str, tuple[float, bool]]:
    """(value, final) of each response's last estimate in a run's partial.csv (none while the
    file is missing; damaged rows are skipped)."""
    reports = LatestReports(partial_csv)
    reports.read_on()
    return dict(reports.latest)


def replicate_record(
    study: Study, replicate: ReplicateFiles, source: str = "job"
) -> ArchivedSimulation:
    """The record of one scene replicate from its results files (`from_results`);
    SimulationFailed saying why there is none: no responses yet, a damaged file, or a
    simulation that never started."""
    if not replicate.responses.is_file():
        raise SimulationFailed(f"{replicate.dir}: no responses.json yet")
    simulation = SimulationRecord.read(replicate.simulation)
    responses = ResponsesRecord.read(replicate.responses)
    if not simulation.ran:
        raise SimulationFailed(f"{replicate.dir}: never started ({simulation.reason})")
    return from_results(study, simulation, responses, replicate.partial, source)


def from_results(
    study: Study,
    simulation: SimulationRecord,
    responses: ResponsesRecord,
    partial_csv: Path | None = None,
    source: str = "job",
) -> ArchivedSimulation:
    """The archive record of one scene replicate from its results files.

    ``study`` is the frozen study the job worked from (free parameters, units); the status
    and reason are those of ``responses`` (an ok run whose responses could not be computed
    is failed there). A terminated run keeps the last estimates of its ``partial_csv``.
    """
    scene = study.scenes.get(simulation.scene)
    response_units = {} if scene is None else {n: r.unit for n, r in scene.responses.items()}
    setting_specs = {} if scene is None else scene.settings
    setting_units = {n: spec.unit for n, spec in setting_specs.items()}
    variable = {
        name: Quantity(float(simulation.settings[name]), spec.unit)
        for name, spec in setting_specs.items()
        if spec.variable and name in simulation.settings
    }
    status = Status(responses.status)
    values: dict[str, tuple[float, bool]] = {}
    if status == Status.OK:
        values = {name: (value, True) for name, value in responses.responses.items()}
    elif status == Status.TERMINATED and partial_csv is not None:
        values = partial_estimates(partial_csv)
    free = {p.name for p in study.free}
    return ArchivedSimulation(
        study=study.name,
        evaluation=simulation.evaluation,
        scene=simulation.scene,
        replicate=simulation.replicate,
        engine=simulation.engine,
        engine_version=simulation.engine_version,
        settings=simulation.settings,
        timestep_fraction=simulation.timestep_fraction,
        status=status,
        reason=responses.reason,
        attempt=simulation.attempt,
        seed=simulation.seed,
        parameters={
            **{
                name: Quantity(float(value), CATALOG[name].unit if name in CATALOG else "")
                for name, value in simulation.parameters.items()
            },
            **variable,
        },
        free=frozenset(free & (set(simulation.parameters) | set(variable))),
        psd={
            name: Quantity(float(simulation.settings[name]), setting_units.get(name, ""))
            for name in PSD_SETTINGS
            if name in simulation.settings
        },
        responses={
            name: Quantity(value, response_units.get(name, ""))
            for name, (value, _) in values.items()
        },
        final={name: final for name, (_, final) in values.items()},
        cost=simulation.cost,
        started_at=simulation.started_at,
        ended_at=simulation.ended_at,
        demcal_version=demcal_version(),
        source=source,
        simulator=digest(simulation.simulator) if simulation.simulator else "",
        fidelity=simulation.fidelity or FINE,
        fine_level=_fine_level(study, simulation.scene),
    )


def _fine_level(study: Study, scene: str) -> str:
    """The digest of the study's fine level of ``scene``; "" when it cannot be told (a scene
    the study no longer has, a simulator's file gone)."""
    try:
        return digest(study.fine_level_view(scene))
    except (KeyError, OSError):
        return ""
