"""Shared test helpers (``from helpers import ...``): tiny studies on the analytic engine, the
demcal CLI, calibrations in this process, synthetic heaps. The fixtures are in conftest.py."""

from __future__ import annotations

import copy
import csv
import importlib
import math
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from demcal.daemon.loop import Calibration
from demcal.jobs.steps import archive, extract, objective, response_paths, simulate
from demcal.results.layout import EvaluationFiles
from demcal.results.records import ObjectiveRecord, Status
from demcal.results.storage import PARTIAL_COLUMNS
from demcal.scenes import SCENES
from demcal.study.config import load_study
from demcal.study.model import Study, freeze

ANALYTIC_STUDY = {
    "study": "unit",
    "engine": {"name": "analytic", "noise": 0.0},
    "parameters": {
        "sliding_friction_pp": {"lower": 0.1, "upper": 0.9},
        "rolling_friction_pp": {"lower": 0.02, "upper": 0.3},
    },
    "fixed": {"restitution_pp": 0.5},
    "targets": [
        {"scene": "cylinder_lift", "response": "angle_of_repose", "value": 25.0, "unit": "deg"},
        {"scene": "cylinder_lift", "response": "bulk_density", "value": 1450.0, "unit": "kg/m^3"},
    ],
    "replicates": 2,
    "seed": 3,
}


def tiny_job(scene: str, workdir: Path, responses=None, fraction: float = 0.25, **params):
    """One simulation of ``scene`` at its ``TINY_SETTINGS`` (seed 7), the catalogue's default
    material changed by ``params``; every response of the scene unless ``responses``."""
    from demcal.engines.base import SimulationJob
    from demcal.physics.catalogue import CATALOG

    declared = SCENES.load(scene)
    tiny = importlib.import_module(f"demcal.scenes.{scene}").TINY_SETTINGS
    return SimulationJob(
        scene=scene,
        parameters={**{name: spec.default for name, spec in CATALOG.items()}, **params},
        settings=declared.resolve_settings(tiny, "s"),
        seed=7,
        responses=list(responses or declared.responses),
        timestep_fraction=fraction,
        workdir=str(workdir),
        stop_file=str(Path(workdir) / "STOP"),
    )


def run_lammps(job):
    """Run one simulation on LAMMPS; its responses as the extract job computes them."""
    from demcal.engines.lammps import LammpsEngine

    return run_and_extract(LammpsEngine(), job)


def run_lammps_stopped(job, after: float = 1.5):
    """Run ``job`` on LAMMPS with its STOP file written ``after`` seconds in; the result."""
    import threading

    timer = threading.Timer(after, Path(job.stop_file).touch)
    timer.start()
    result, _ = run_lammps(job)
    timer.join()
    return result


def run_and_extract(engine, job):
    """Run one simulation on ``engine``; its responses as the extract job computes them."""
    from demcal.engines.base import RunMonitor
    from demcal.jobs.steps import scene_responses
    from demcal.results.records import Status

    scene = SCENES.load(job.scene)
    result = engine.run(job, RunMonitor(job), scene.driver(engine.name))
    responses = {}
    if result.status == Status.OK:
        responses = scene_responses(
            scene, job.responses, result.measurements, lambda: result.arrays, job.settings
        )
    return result, responses


#: Corners of the parameter box every scene must survive (stable, plausible responses).
PARAMETER_CORNERS = {
    "frictionless": dict(
        sliding_friction_pp=0.0,
        sliding_friction_pw=0.0,
        rolling_friction_pp=0.0,
        rolling_friction_pw=0.0,
    ),
    "full_friction": dict(
        sliding_friction_pp=1.0,
        sliding_friction_pw=1.0,
        rolling_friction_pp=1.0,
        rolling_friction_pw=1.0,
    ),
    "restitution_0.05": dict(restitution_pp=0.05, restitution_pw=0.05),
    "restitution_0.95": dict(restitution_pp=0.95, restitution_pw=0.95),
    "stiff_5e8_Pa": dict(youngs_modulus=5.0e8),
}
#: A very cohesive material: Bond number 41 for the tiny scenes' 3 mm spheres, lumps that
#: stick to the walls.
COHESIVE_CORNER = dict(surface_energy_pp=2.0, surface_energy_pw=2.0)


def cohesive_corner_problem(job, must_measure: bool = False) -> str | None:
    """Run ``job`` (at ``COHESIVE_CORNER``) on LAMMPS; what went wrong, or None if it ran
    stably with every response in its physical range (a bulk density at most the particle
    density), or failed for a reason that names a cause other than instability (a lump that
    never left its container measures nothing) unless ``must_measure``."""
    from demcal.errors import SimulationFailed

    try:
        result, responses = run_lammps(job)
    except SimulationFailed as failure:  # the extractor found nothing to measure
        return f"nothing measured: {failure}" if must_measure else None
    if result.status != Status.OK:
        return result.reason if must_measure or "unstable" in result.reason else None
    specs = SCENES.load(job.scene).responses
    upper = {"bulk_density": job.parameters["particle_density"]}
    outside = {
        name: value
        for name, value in responses.items()
        if not specs[name].lower <= value <= min(specs[name].upper, upper.get(name, math.inf))
    }
    return f"outside the physical range: {outside}" if outside else None


def cone_of_spheres(
    angle_deg: float, base_radius: float, d: float, plateau_radius: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Spheres of diameter d stacked in columns so the surface is a cone (or a mesa).

    Surface height at distance rho: (base_radius - max(rho, plateau_radius)) tan(angle);
    each column holds spheres up to that height.
    """
    slope = math.tan(math.radians(angle_deg))
    positions = []
    n = int(base_radius / d) + 1
    for i in range(-n, n + 1):
        for j in range(-n, n + 1):
            x, y = (i + 0.5) * d, (j + 0.5) * d
            rho = math.hypot(x, y)
            height = (base_radius - max(rho, plateau_radius)) * slope
            layers = max(1, int(round(height / d)))
            if rho > base_radius:
                continue
            positions += [(x, y, d / 2 + k * d) for k in range(layers)]
    x = np.array(positions)
    return x, np.full(len(x), d / 2)


# -- calibrations through the demcal CLI (tests/daemon/test_daemon.py, workflow/test_slurm.py) --

ROOT = Path(__file__).resolve().parents[1]
TRUTH = {"sliding_friction_pp": 0.4, "rolling_friction_pp": 0.1}


def true_targets(truth: dict = TRUTH):
    """Responses of the closed form at ``truth``: the calibration's known optimum."""
    params = {
        "sliding_friction_pw": 0.5,
        "rolling_friction_pw": 0.1,
        "restitution_pp": 0.5,
        "youngs_modulus": 5e6,
        "poisson_ratio": 0.3,
        "particle_density": 2500.0,
        **truth,
    }
    exact = SCENES.load("cylinder_lift").analytic_model(params, {})
    units = {name: spec.unit for name, spec in SCENES.load("cylinder_lift").responses.items()}
    return [
        {"scene": "cylinder_lift", "response": name, "value": value, "unit": units[name]}
        for name, value in exact.items()
    ]


def study(tmp_path, name, **overrides):
    config = {
        "study": name,
        "engine": {"name": "analytic", "noise": 0.0, "duration": 0.5},
        "parameters": {
            "sliding_friction_pp": {"lower": 0.1, "upper": 0.9},
            "rolling_friction_pp": {"lower": 0.02, "upper": 0.3},
        },
        "targets": true_targets(),
        # the fast response model: these tests are about the daemon, not the model
        # (Kriging per response is tested in tests/optimizer)
        "optimizer": {"max_evaluations": 14, "response_model": "cubic_rbf"},
        "calibration": {"workers": 2, "poll_seconds": 0.3, "retries": 1},
        "seed": 5,
    }
    for key, value in overrides.items():
        config[key] = {**config.get(key, {}), **value} if isinstance(value, dict) else value
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(config))
    return path


def demcal(tmp_path, *args, **popen):
    command = [sys.executable, "-m", "demcal.cli", *map(str, args)]
    return subprocess.Popen(
        command,
        cwd=tmp_path,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **popen,
    )


def finish(proc, timeout=240):
    out, err = proc.communicate(timeout=timeout)
    assert proc.returncode == 0, err[-3000:]
    return out


def evaluations(tmp_path, name):
    return pd.read_csv(tmp_path / "results" / name / "evaluations.csv")


# -- a calibration of the analytic example run in-process (no Snakemake) --

ANALYTIC_EXAMPLE = ROOT / "config" / "examples" / "analytic.yaml"


def analytic_example(**overrides) -> dict:
    """config/examples/analytic.yaml without its fake run time, with ``overrides`` merged in."""
    config = yaml.safe_load(ANALYTIC_EXAMPLE.read_text())
    config["engine"]["duration"] = 0.0
    for key, value in overrides.items():
        config[key] = {**config.get(key, {}), **value} if isinstance(value, dict) else value
    return config


def new_optimizer(study):
    """The optimizer a calibration of ``study`` starts with (as the daemon makes it)."""
    from demcal.optimizer import Optimizer
    from demcal.optimizer.objective import ResponseObjective

    return Optimizer(
        [p.lower for p in study.free],
        [p.upper for p in study.free],
        study.optimizer,
        seed=study.seed,
        objective=ResponseObjective(tuple(study.targets), study.objective_form),
    )


def evaluate(study, optimizer, proposal) -> dict:
    """Write a proposal's params.json, run its simulate, extract, objective and archive jobs in
    this process, tell the optimizer, save its state; the objective record (as a dict)."""
    from demcal.results.layout import evaluation_id
    from demcal.results.records import PointRecord
    from demcal.results.storage import atomic_write_text

    evaluation = evaluation_id(proposal.id)
    files = study.files.evaluation(evaluation)
    names = [p.name for p in study.free]
    point = PointRecord(dict(zip(names, proposal.x)), in_initial_design=proposal.in_initial_design)
    point.write(files.params)
    for scene in study.scenes:
        for replicate in range(study.replicates):
            simulate(study, evaluation, scene, replicate)
            extract(study, files.replicate(scene, replicate).simulation)
    record = objective(study, evaluation, response_paths(study, evaluation)).to_dict()
    archive(study, evaluation)
    if record["status"] == Status.OK:
        optimizer.tell(proposal.id, responses=record["replicates"])
    else:
        optimizer.tell(proposal.id, status=record["status"])
    atomic_write_text(study.files.optimizer, optimizer.to_json())
    return record


def run_in_process(study, evaluations: int, extra_points=(), reason="evaluation budget spent"):
    """A finished calibration of ``study`` without Snakemake: the first ``evaluations`` points
    the optimizer asks for and then ``extra_points`` (given by hand), each evaluated in
    process, then the tables and finished.json as the daemon writes them; the optimizer."""
    import time

    from demcal.daemon.tables import write_best, write_evaluations_csv
    from demcal.results.storage import write_json

    write_json(study.files.calibration, {"started_at": time.time(), "study": study.name})
    optimizer = new_optimizer(study)
    for _ in range(evaluations):
        (proposal,) = optimizer.ask(1)
        evaluate(study, optimizer, proposal)
    for point in extra_points:
        evaluate(study, optimizer, optimizer.add_point(point))
    write_evaluations_csv(study)
    best = optimizer.best()
    if best is not None:
        write_best(study, best, optimizer.confirmation(), reason)
    write_json(
        study.files.finished,
        {"reason": reason, "ended_at": time.time(), "evaluations": optimizer.status_counts()},
    )
    return optimizer


def read_objective(files) -> dict:
    """An evaluation's objective record as it stands (a re-score, else its job's), as a dict."""
    from demcal.results.records import ObjectiveRecord

    return ObjectiveRecord.read_latest(files).to_dict()


# -- calibrations in this process: the jobs run here, no Snakemake (tests/daemon) --


@dataclass
class Ended:
    """An evaluation that ran to its end within ``launch``."""

    evaluation: str
    started: float
    pid: int = -1

    def finished(self) -> bool:
        return True

    def returncode(self) -> int | None:
        return 0


def run_simulations(study: Study, files: EvaluationFiles) -> None:
    """The simulate and extract jobs of every scene replicate whose output is missing (as
    Snakemake runs them: a child launched again redoes no simulation)."""
    for scene in study.scenes:
        for replicate in range(study.replicates):
            replicate_files = files.replicate(scene, replicate)
            if not replicate_files.simulation.exists():
                simulate(study, files.id, scene, replicate)
            if not replicate_files.responses.exists():
                extract(study, replicate_files.simulation)


def run_last_jobs(study: Study, files: EvaluationFiles) -> None:
    """The objective and archive jobs, where their outputs are missing."""
    if not files.objective.exists():
        objective(study, files.id, response_paths(study, files.id))
    if not files.archived.exists():
        archive(study, files.id)


@dataclass
class InProcessLauncher:
    """Runs simulate -> extract -> objective, archive of every scene replicate in this process."""

    study: Study
    fail: tuple[str, ...] = ()

    def __post_init__(self):
        self.launched: list[str] = []

    def launch(self, files: EvaluationFiles) -> Ended:
        self.launched.append(files.id)
        if files.id in self.fail and self.launched.count(files.id) == 1:
            ObjectiveRecord(files.id, Status.FAILED, "node lost").write(files.objective)
            return Ended(files.id, time.time())
        run_simulations(self.study, files)
        run_last_jobs(self.study, files)
        return Ended(files.id, time.time())

    def reattach(self, files: EvaluationFiles) -> None:
        return None


def config(**changes) -> dict:
    study = copy.deepcopy(ANALYTIC_STUDY)
    study.update(
        optimizer={"max_evaluations": 8, "early_termination": {"enabled": False}},
        calibration={"poll_seconds": 0.001, "retries": 1},
        **changes,
    )
    return study


def calibrate(study_config: dict, **launcher) -> tuple[Calibration, InProcessLauncher, str]:
    study = freeze(load_study(study_config))
    runner = InProcessLauncher(study, **launcher)
    calibration = Calibration(study, runner, workers=2)
    return calibration, runner, calibration.run(show_progress=lambda progress: None)


def write_partial(files: EvaluationFiles, replicate: int, rows: list[tuple]) -> None:
    """A replicate's partial.csv with rows (wall_s, progress, stage, response, value, final)."""
    path = files.replicate("cylinder_lift", replicate).partial
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as handle:
        csv.writer(handle).writerows([PARTIAL_COLUMNS, *rows])


def run_calibration(study_config: dict) -> Calibration:
    """A calibration run in this process, one worker at a time (InProcessLauncher)."""
    study = freeze(load_study(study_config))
    calibration = Calibration(study, InProcessLauncher(study), workers=1)
    calibration.run(show_progress=lambda progress: None)
    return calibration
