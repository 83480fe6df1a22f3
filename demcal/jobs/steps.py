"""The jobs of one evaluation's DAG: simulate -> extract -> objective, and archive.

The archive job records the evaluation's simulations in the study's archive
(``demcal.archive``), on the machine where Snakemake runs; a staged simulation waits for
its ``release`` job (:func:`release_marker`).
Files of evaluation ``<id>`` under ``results/<study>/evals/<id>/``
(``demcal.results.layout``): ``params.json`` (written by whoever proposes the point),
per scene and replicate ``<scene>/rep<r>/simulation.json`` (+ ``state.npz``
when responses are computed from particle positions), ``partial.csv`` while
running, ``responses.json``, and ``objective.json`` (and ``rescored.json``, the same
record against corrected targets: :func:`rescore`). Every record carries
``status`` (ok | terminated | failed) and, unless ok, a ``reason``. A job
never fails the DAG for a simulation's fault: it records the failure and
exits 0. Jobs work from the frozen study (``demcal.study.model.load_frozen``).
"""

from __future__ import annotations

import logging
import os
import platform
import time
import traceback
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from demcal.engines.base import Engine, RunMonitor, RunResult, SimulationJob
from demcal.errors import ConfigError, DemcalError, SimulationFailed, bounded_reason
from demcal.optimizer.objective import relative_miss, replicate_mean, replicate_spread
from demcal.results.layout import EvaluationFiles, ReplicateFiles
from demcal.results.records import (
    FINE,
    NOT_STARTED,
    ObjectiveRecord,
    PointRecord,
    ResponsesRecord,
    ReusedRecord,
    SimulationRecord,
    Status,
)
from demcal.results.storage import atomic_write_text
from demcal.scenes.base import Scene
from demcal.snakemake_command import ScriptJob
from demcal.study.model import Study, load_frozen

log = logging.getLogger("demcal")


def response_paths(study: Study, evaluation: str) -> list[Path]:
    """The responses.json of every scene replicate of an evaluation (the objective's inputs)."""
    files = study.files.evaluation(evaluation)
    return [
        files.replicate(scene, r).responses
        for scene in study.scenes
        for r in range(study.replicates)
    ]


def staged_inputs(study: Study, evaluation: str, scene: str, replicate: int) -> list[Path]:
    """The responses.json a simulation waits for in a staged study (``Study.staging``).

    Replicate 0 of a scene in the staging order waits for replicate 0 of the
    scene before it; every other replicate waits for replicate 0 of every
    scene. So the first simulations are judged by early termination
    (Samuelsson 2023, sec. 5.1.2: a stopped evaluation costs a fraction of
    its replicates) before the rest start. Nothing in a parallel study, nor
    for an evaluation that cannot be stopped (its params.json not ``staged``:
    the initial design, confirmations, campaigns, points given by hand).
    """
    if study.staging is None:
        return []
    files = study.files.evaluation(evaluation)
    try:
        if not PointRecord.read(files.params).staged:
            return []
    except SimulationFailed:  # the simulate job records what is wrong with params.json
        return []
    if replicate > 0:
        return [files.replicate(name, 0).responses for name in study.scenes]
    order = study.staging
    if scene in order[1:]:
        return [files.replicate(order[order.index(scene) - 1], 0).responses]
    return []


def release_marker(study: Study, evaluation: str, scene: str, replicate: int) -> list[Path]:
    """The file a staged simulation waits for (the ``release`` job's output, after its
    ``staged_inputs``), or [] when it waits for nothing. Between the staged simulations
    stands this local job, so that each simulation stays its own SLURM job: a direct edge
    would merge them into one Snakemake group job, whose jobs run one after another."""
    if not staged_inputs(study, evaluation, scene, replicate):
        return []
    return [study.files.evaluation(evaluation).replicate(scene, replicate).released]


def not_started(study: Study, evaluation: str, scene: str, replicate: int) -> RunResult | None:
    """Why a simulation is not to start (its evaluation was stopped, or a simulation it waits
    for failed or was stopped), as its result; None when it should run."""
    files = study.files.evaluation(evaluation)
    if files.stop.exists():
        return RunResult(Status.TERMINATED, f"{NOT_STARTED}the evaluation was stopped early")
    for path in staged_inputs(study, evaluation, scene, replicate):
        if not path.exists():  # a DAG built before the study was staged: nothing to wait for
            continue
        before = ResponsesRecord.read(path)
        if before.status != Status.OK:
            label = f"{path.parent.parent.name} {path.parent.name}"
            return RunResult(Status.TERMINATED, f"{NOT_STARTED}{label} {before.status}")
    return None


#: Why an evaluation stopped by a STOP file that gives no reason was stopped.
STOPPED_BY_HAND = "stopped early by a STOP file that gives no reason (one made by hand)"


def ask_to_stop(files: EvaluationFiles, reason: str) -> None:
    """Ask the evaluation's running simulations to stop: its STOP file, saying who stopped it
    and why (its objective job gives that as the reason it was stopped)."""
    atomic_write_text(files.stop, reason)


def stop_reason(files: EvaluationFiles) -> str:
    """Why the evaluation was stopped, as its STOP file says (`ask_to_stop`)."""
    try:
        given = files.stop.read_text(errors="replace").strip()
    except OSError:  # removed by hand since
        given = ""
    return bounded_reason(given) if given else STOPPED_BY_HAND


def simulator_of(
    study: Study, scene: str, fidelity: str = FINE
) -> tuple[dict[str, Any], RunResult | None]:
    """What simulates ``scene`` at level ``fidelity`` (`Study.simulator`), read before the
    run; when a file it names cannot be read, {} and the failed result that records why (the
    run does not start)."""
    try:
        return study.simulator(scene, fidelity), None
    except OSError as exc:
        return {}, RunResult(Status.FAILED, f"cannot read the simulator's files: {exc}")


def simulate(study: Study, evaluation: str, scene: str, replicate: int) -> SimulationRecord:
    """Run one scene replicate; write and return its simulation.json record."""
    files = study.files.evaluation(evaluation)
    replicate_files = files.replicate(scene, replicate)
    workdir = replicate_files.dir
    workdir.mkdir(parents=True, exist_ok=True)
    replicate_files.state.unlink(missing_ok=True)
    started_at = time.time()
    level = study.level()
    try:
        point = PointRecord.read(files.params)
        level = study.level(point.level)
        attempt = point.attempt
        parameters = study.parameters_for(point.parameters, replicate)
        settings = study.settings_for(scene, point.parameters, level.name)
        avoid = reused_seeds(study)
    except (ConfigError, SimulationFailed) as exc:
        result = RunResult(Status.FAILED, f"bad parameters: {exc}")
        parameters, settings, seed, attempt = {}, level.settings[scene], None, None
        simulator, _ = simulator_of(study, scene, level.name)
    else:
        simulator, unreadable = simulator_of(study, scene, level.name)
        seed = study.simulation_seed(evaluation, scene, replicate, point.attempt, avoid)
        job = SimulationJob(
            scene=scene,
            parameters=parameters,
            settings=settings,
            seed=seed,
            responses=study.responses_needed(scene),
            timestep_fraction=level.timestep_fraction,
            workdir=str(workdir.resolve()),
            stop_file=str(files.stop.resolve()),
            attempt=point.attempt,
        )
        result = (
            not_started(study, evaluation, scene, replicate)
            or unreadable
            or run_engine(study, job, level.engine)
        )
    state_file = None
    if result.status == Status.OK and result.arrays:
        # numpy's stub types **kwds as if a key could be its allow_pickle: bool
        np.savez(replicate_files.state, **result.arrays)  # type: ignore[arg-type]
        state_file = replicate_files.state.name
    record = SimulationRecord(
        evaluation=evaluation,
        scene=scene,
        replicate=replicate,
        engine=level.engine.name,
        engine_version=level.engine.version(),
        simulator=simulator,
        settings=settings,
        timestep_fraction=level.timestep_fraction,
        responses_needed=study.responses_needed(scene),
        started_at=started_at,
        state_file=state_file,
        seed=seed,
        attempt=attempt,
        parameters=parameters,
        status=Status(result.status),
        reason=bounded_reason(result.reason),
        measurements=result.measurements,
        cost=result.cost,
        ended_at=time.time(),
        fidelity=None if level.name == FINE else level.name,
    )
    record.write(replicate_files.simulation)
    log.info(
        "simulation %s %s rep%d: %s %s", evaluation, scene, replicate, result.status, result.reason
    )
    return record


def reused_seeds(study: Study) -> frozenset[int]:
    """The seeds of the simulations the study reused (``reused.json``; none without reuse)."""
    if study.reuse is None or not study.files.reused.exists():
        return frozenset()
    return ReusedRecord.read(study.files.reused).seeds


def run_engine(study: Study, job: SimulationJob, engine: Engine | None = None) -> RunResult:
    """The run of ``engine`` (the study's, unless a fidelity level has its own); any error it
    raises becomes a failed result with the reason."""
    engine = study.engine if engine is None else engine
    try:
        driver = study.scenes[job.scene].driver(engine.name)
        return engine.run(job, RunMonitor(job), driver)
    except SimulationFailed as exc:
        return RunResult(Status.FAILED, str(exc))
    except Exception as exc:  # an engine bug must not lose the evaluation
        log.error("engine %s raised:\n%s", engine.name, traceback.format_exc())
        return RunResult(Status.FAILED, f"engine error: {type(exc).__name__}: {exc}")


def extract(study: Study, simulation_path: Path) -> ResponsesRecord:
    """Responses of one simulation: measured by the engine or computed by the scene."""
    simulation_path = Path(simulation_path)
    sim: SimulationRecord | None = None  # the simulation, once its file is read
    try:
        sim = SimulationRecord.read(simulation_path)
        record = ResponsesRecord(
            sim.status,
            bounded_reason(sim.reason),
            evaluation=sim.evaluation,
            scene=sim.scene,
            replicate=sim.replicate,
            seed=sim.seed,
            cost=sim.cost,
        )
        if sim.status == Status.OK:
            record = replace(record, responses=_responses(study, sim, simulation_path.parent))
    except SimulationFailed as exc:
        record = ResponsesRecord(Status.FAILED, str(exc))
    except (KeyError, TypeError, ValueError) as exc:
        record = ResponsesRecord(
            Status.FAILED,
            f"simulation.json malformed or response not measurable: {type(exc).__name__}: {exc}",
        )
    record.write(ReplicateFiles(simulation_path.parent).responses)
    return record


def archive(study: Study, evaluation: str) -> int:
    """The archive job: every simulation of an evaluation that ran, recorded in the study's
    archive (demcal.archive) in one transaction, then the evaluation's ``archived`` mark;
    returns how many records were new.

    A local job, never a cluster one: an SQLite archive must not be written from several
    nodes. A failure is a warning in the job's log, never the evaluation's: the results
    files stay, and ``demcal archive import`` records them later.
    """
    from demcal.archive.simulation import replicate_record
    from demcal.archive.store import Archive
    from demcal.results.archive_url import shown

    files, added = study.files.evaluation(evaluation), 0
    if study.archive is not None:
        records = []
        for path in response_paths(study, evaluation):
            try:
                records.append(replicate_record(study, ReplicateFiles(path.parent)))
            except SimulationFailed:
                continue  # not run, or its extract job failed: nothing to record
        try:
            with Archive(study.archive) as store:
                added = store.add(records)
        except Exception as exc:  # noqa: BLE001  (whatever the archive's fault, the evaluation stands)
            log.warning(
                "the simulations of %s not archived (%s: %s); 'demcal archive import --url %s "
                "%s' records them from the results files",
                evaluation,
                type(exc).__name__,
                exc,
                shown(study.archive),
                study.files.dir,
            )
    files.archived.touch()
    return added


def _responses(study: Study, sim: SimulationRecord, workdir: Path) -> dict[str, float]:
    return scene_responses(
        study.scenes[sim.scene],
        study.responses_needed(sim.scene),
        sim.measurements,
        lambda: _load_state(workdir, sim),
        sim.settings,
    )


def scene_responses(
    scene: Scene,
    wanted: list[str],
    measurements: dict[str, float],
    load_state: Callable[[], dict[str, np.ndarray]],
    settings: dict[str, Any],
) -> dict[str, float]:
    """Each wanted response: measured by the engine, else computed by the scene from the state.

    ``load_state`` is called at most once, and only if some response needs it.
    """
    state = None
    out = {}
    for name in wanted:
        if name in measurements:
            value = measurements[name]
        else:
            if state is None:
                state = load_state()
            value = scene.extractors[name](state, settings)
        if value is None or not np.isfinite(value):
            raise SimulationFailed(f"response {name} is not a finite number ({value})")
        out[name] = float(value)
    return out


def _load_state(workdir: Path, sim: SimulationRecord) -> dict[str, np.ndarray]:
    if sim.state_file is None:
        raise SimulationFailed("simulation saved no particle state to extract responses from")
    try:
        with np.load(workdir / sim.state_file) as data:
            return {k: data[k] for k in data.files}
    except (OSError, ValueError) as exc:
        raise SimulationFailed(f"particle state unreadable: {exc}") from None


def objective(study: Study, evaluation: str, response_paths: list[Path]) -> ObjectiveRecord:
    """The objective job: :func:`objective_record`, written to the evaluation's objective.json."""
    record = objective_record(study, evaluation, response_paths)
    record.write(study.files.evaluation(evaluation).objective)
    return record


def objective_record(study: Study, evaluation: str, response_paths: list[Path]) -> ObjectiveRecord:
    """Objective record of an evaluation from all its replicates' responses.

    Replicates are averaged per response before the relative error is taken
    (Samuelsson 2023, eq. 3.3 and sec. 2.5). Any failed replicate fails the
    evaluation (reasons kept); any terminated one terminates it.
    """
    values: dict[str, list[float]] = defaultdict(list)
    failures, terminated, cpu, wall = [], False, 0.0, 0.0
    for path in response_paths:
        try:
            rec = ResponsesRecord.read(path)
        except SimulationFailed as exc:
            rec = ResponsesRecord(Status.FAILED, str(exc))
        scene = Path(path).parent.parent.name if rec.scene is None else rec.scene
        label = f"{scene} rep{'?' if rec.replicate is None else rec.replicate}"
        cost = rec.cost or {}
        cpu += float(cost.get("cpu_s", 0.0))
        wall += float(cost.get("wall_s", 0.0))
        if rec.status == Status.FAILED:
            failures.append(f"{label}: {rec.reason or 'unknown reason'}")
        elif rec.status == Status.TERMINATED:
            terminated = True
        else:
            for name, value in rec.responses.items():
                values[f"{rec.scene}.{name}"].append(value)
    files = study.files.evaluation(evaluation)
    try:
        point = PointRecord.read(files.params).parameters
    except SimulationFailed:
        point = {}
    record = ObjectiveRecord(
        evaluation, Status.OK, parameters=point, cost={"cpu_s": cpu, "simulation_wall_s": wall}
    )
    if failures:
        record = replace(record, status=Status.FAILED, reason=bounded_reason("; ".join(failures)))
    elif terminated:
        record = replace(record, status=Status.TERMINATED, reason=stop_reason(files))
    elif missing := [t.key for t in study.targets if t.key not in values]:
        record = replace(
            record, status=Status.FAILED, reason=f"no value for targeted responses {missing}"
        )
    else:
        record = score(study, record, dict(values))
    return record


def score(
    study: Study, record: ObjectiveRecord, replicates: dict[str, list[float]]
) -> ObjectiveRecord:
    """``record`` scored by the study's objective (eq. 3.3 plus the Rayleigh cost) from the
    replicates' responses, or failed with the reason."""
    try:
        timestep_cost = study.timestep_cost(record.parameters)
    except DemcalError as exc:
        return replace(record, status=Status.FAILED, reason=f"Rayleigh time-step cost: {exc}")
    objective = study.objective
    means = {key: replicate_mean(v) for key, v in replicates.items()}  # Samuelsson 2023, 2.5
    try:
        value = objective.of_replicates(replicates, timestep_cost)
    except ValueError as exc:
        return replace(record, status=Status.FAILED, reason=str(exc))
    return replace(
        record,
        status=Status.OK,
        reason="",
        objective=value,
        timestep_cost=timestep_cost,
        responses=means,
        replicates=replicates,
        spread={key: replicate_spread(v) for key, v in replicates.items()},
        relative_errors={t.key: relative_miss(t, means[t.key]) for t in study.targets},
        scored_with=objective.version,
    )


def rescore(study: Study, files: EvaluationFiles, record: ObjectiveRecord) -> ObjectiveRecord:
    """An evaluation's objective against the study's current targets, from the replicates'
    responses its objective job kept in ``record`` (its ``objective.json``; no simulation
    runs), written to ``rescored.json``."""
    rescored = score(study, replace(record, reason=""), record.replicates)
    rescored.write(files.rescored)
    return rescored


@dataclass(frozen=True)
class ReusedOrigin:
    """Where a reused point comes from: the study's level it ran at, and for a neighbouring
    material its values of the fixed parameters that differ from the study's (else empty)."""

    fidelity: str
    material: dict[str, float]


def reused_origins(study: Study) -> dict[str, ReusedOrigin]:
    """The origin of each point the study reused (``reused.json``), by its source."""
    reused = ReusedRecord.read_if_any(study.files.reused)
    return {
        p["source"]: ReusedOrigin(p.get("fidelity", FINE), p.get("material", {}))
        for p in ([] if reused is None else reused.points)
    }


def reused_objectives(study: Study) -> list[ObjectiveRecord]:
    """The points the study reused (``reused.json``), each scored by the study's objective as
    it stands now (its targets may have changed since; a partial point, `partial_record`);
    [] when it reused none. Each record's ``evaluation`` is the point's source,
    ``study/evaluation``."""
    reused = ReusedRecord.read_if_any(study.files.reused)
    return [
        partial_record(p)
        if p.get("partial")
        else score(
            study,
            ObjectiveRecord(p["source"], Status.OK, parameters=p["parameters"]),
            p["replicates"],
        )
        for p in ([] if reused is None else reused.points)
    ]


def partial_record(point: dict[str, Any]) -> ObjectiveRecord:
    """A reused point where only some targeted responses ran: no objective, like a run stopped
    early (``terminated``), its responses data of their models only."""
    replicates = point["replicates"]
    return ObjectiveRecord(
        point["source"],
        Status.TERMINATED,
        reason=f"reused with {', '.join(sorted(replicates))} only: data of their models",
        parameters=point["parameters"],
        responses={key: replicate_mean(values) for key, values in replicates.items()},
        replicates=replicates,
        spread={key: replicate_spread(values) for key, values in replicates.items()},
    )


def run_snakemake_job(smk: ScriptJob, stage: str) -> None:
    """Entry point of the workflow's scripts: log to the rule's log, run one stage."""
    logging.basicConfig(
        filename=smk.log[0],
        level=logging.INFO,
        force=True,
        format="%(asctime)s %(levelname)s %(message)s",
    )
    where = os.environ.get("SLURM_JOB_ID")
    log.info("%s job on %s%s", stage, platform.node(), f", SLURM job {where}" if where else "")
    try:
        study = load_frozen(smk.params.study_file)
        w = smk.wildcards
        if stage == "simulate":
            simulate(study, w.evaluation, w.scene, int(w.replicate))
        elif stage == "extract":
            extract(study, Path(smk.input[0]))
        elif stage == "archive":
            archive(study, w.evaluation)
        else:
            objective(study, w.evaluation, [Path(p) for p in smk.input])
    except DemcalError as exc:
        log.error("%s", exc)
        raise SystemExit(f"demcal {stage}: {exc}") from None


def write_centre_point(smk: ScriptJob) -> None:
    """params.json at the centre of the free parameters' bounds (the default evaluation)."""
    study = load_frozen(smk.params.study_file)
    PointRecord(study.centre_point(), proposed_by="centre of the bounds").write(Path(smk.output[0]))
