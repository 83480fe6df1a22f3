"""The results layout: every path and file name under ``results/<study>/``.

One study, its evaluations and their scene replicates each get a small
frozen object that knows its files; nobody else spells a file name. Paths
are relative to the working directory (Snakemake's targets are), and the
objects accept wildcard strings (``"{evaluation}"``, ``"{replicate}"``) so the
workflow's rules build their patterns from the same place::

    results/<study>/
        study.json          the resolved study, frozen at the start (demcal.study.model)
        calibration.json    start time of the calibration
        optimizer.json      the optimizer's whole state, rewritten after every event
        evaluations.csv     one row per evaluation (demcal.daemon.tables)
        best.json           the best point so far
        finished.json       written only when the calibration has ended, with its reason
        reused.json         the archive's simulations the study started from (reuse: archive)
        campaign.json, campaign.log  a sampling campaign's design and its Snakemake's output
        advice/             which lab test to add (demcal advise): advice.json, advice.png and
                            a joint study file per candidate test
        metamodels/models.pkl  a sampled domain's global metamodels (demcal metamodel build)
        metamodel/<kind>/   a material calibrated on a domain's metamodels of that kind
        early_termination.csv  estimates of running evaluations and their stopping limits
        live.html           the live view of a running calibration (demcal watch)
        daemon.log, daemon.lock, STOP_CALIBRATION, logs/, plots/, report.html
        evals/<id>/
            params.json     the point (parameters, attempt, previous failures)
            launch.json     pid of the child Snakemake running it
            objective.json  status, objective, responses per replicate (its objective job)
            rescored.json   the same, re-scored against corrected targets (the daemon)
            STOP            asks the running simulations to stop
            logs/
            <scene>/rep<r>/ simulation.json, responses.json, partial.csv, state.npz

What each file holds is its record in `demcal.results.records`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

#: The origin of a point reused from the archive: of the study's own material, or of a
#: neighbouring one (evaluations.csv's ``origin``); neither cost this study anything.
REUSED_ORIGINS = ("archive", "neighbouring material")


RESULTS = Path("results")
#: The names of the results files that other modules also need (the records name their file,
#: the engines the files of a run directory, globs find studies and simulations): spelled here
#: once.
SIMULATION_FILE = "simulation.json"
RESPONSES_FILE = "responses.json"
PARTIAL_FILE = "partial.csv"
STATE_FILE = "state.npz"
PARAMS_FILE = "params.json"
OBJECTIVE_FILE = "objective.json"
RESCORED_FILE = "rescored.json"
ARCHIVED_FLAG = "archived"
LAUNCH_FILE = "launch.json"
STOP_FILE = "STOP"
STUDY_FILE = "study.json"
BEST_FILE = "best.json"
ADVICE_FILE = "advice.json"
FINISHED_FILE = "finished.json"
REUSED_FILE = "reused.json"
CAMPAIGN_FILE = "campaign.json"
CALIBRATION_FILE = "calibration.json"
SOLUTIONS_FILE = "solutions.csv"
#: The columns of a study's early_termination.csv (the daemon appends; the figures read): one
#: row each time a running evaluation's estimate changes. ``limit``: what the estimate was held
#: to (empty: none applied); ``judged``: the estimate compared with it (the estimate, or where its
#: falling trend heads).
ESTIMATE_COLUMNS = ("elapsed_s", "evaluation", "running_s", "estimate", "limit", "stop", "judged")


@dataclass(frozen=True)
class ReplicateFiles:
    """One simulation of one scene at one point: ``evals/<id>/<scene>/rep<r>/``."""

    dir: Path

    @property
    def simulation(self) -> Path:
        return self.dir / SIMULATION_FILE

    @property
    def responses(self) -> Path:
        return self.dir / RESPONSES_FILE

    @property
    def partial(self) -> Path:
        return self.dir / PARTIAL_FILE

    @property
    def released(self) -> Path:
        """Marks a staged simulation's turn: the simulations it waits for have ended."""
        return self.dir / "released"

    @property
    def state(self) -> Path:
        return self.dir / STATE_FILE


@dataclass(frozen=True)
class EvaluationFiles:
    """One evaluated point: ``evals/<id>/``."""

    dir: Path

    @property
    def id(self) -> str:
        return self.dir.name

    @property
    def params(self) -> Path:
        return self.dir / PARAMS_FILE

    @property
    def objective(self) -> Path:
        return self.dir / OBJECTIVE_FILE

    @property
    def rescored(self) -> Path:
        return self.dir / RESCORED_FILE

    @property
    def archived(self) -> Path:
        """Marks that the archive job has recorded the evaluation's simulations."""
        return self.dir / ARCHIVED_FLAG

    @property
    def launch(self) -> Path:
        return self.dir / LAUNCH_FILE

    @property
    def stop(self) -> Path:
        return self.dir / STOP_FILE

    @property
    def logs(self) -> Path:
        return self.dir / "logs"

    @property
    def snakemake_log(self) -> Path:
        return self.logs / "snakemake.log"

    def job_log(
        self, stage: str, scene: str | None = None, replicate: int | str | None = None
    ) -> Path:
        """Log of one workflow job (simulate/extract per scene replicate, or objective)."""
        suffix = "" if scene is None else f"_{scene}_rep{replicate}"
        return self.logs / f"{stage}{suffix}.log"

    def scene_dir(self, scene: str) -> Path:
        return self.dir / scene

    def replicate(self, scene: str, replicate: int | str) -> ReplicateFiles:
        return ReplicateFiles(self.dir / scene / f"rep{replicate}")


@dataclass(frozen=True)
class MetamodelCalibrationFiles:
    """A material calibrated on a domain's metamodels of one kind: ``metamodel/<kind>/``."""

    dir: Path

    @property
    def solutions(self) -> Path:
        return self.dir / SOLUTIONS_FILE

    @property
    def solution_space(self) -> Path:
        return self.dir / "solution_space.png"

    @property
    def summary(self) -> Path:
        return self.dir / CALIBRATION_FILE


@dataclass(frozen=True)
class StudyFiles:
    """The results folder of one study: ``results/<study>/``."""

    dir: Path
    evals: Path = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "evals", self.dir / "evals")

    @classmethod
    def of(cls, study_name: str) -> StudyFiles:
        return cls(RESULTS / study_name)

    @property
    def study(self) -> Path:
        return self.dir / STUDY_FILE

    @property
    def calibration(self) -> Path:
        return self.dir / CALIBRATION_FILE

    @property
    def optimizer(self) -> Path:
        return self.dir / "optimizer.json"

    @property
    def evaluations_csv(self) -> Path:
        return self.dir / "evaluations.csv"

    @property
    def evaluations_columns(self) -> Path:
        return self.dir / "evaluations.columns.csv"

    @property
    def best(self) -> Path:
        return self.dir / BEST_FILE

    @property
    def finished(self) -> Path:
        return self.dir / FINISHED_FILE

    @property
    def reused(self) -> Path:
        return self.dir / REUSED_FILE

    @property
    def campaign(self) -> Path:
        return self.dir / CAMPAIGN_FILE

    @property
    def campaign_log(self) -> Path:
        return self.dir / "campaign.log"

    @property
    def fidelity_table(self) -> Path:
        """A fidelity check's comparison of each level with the fine one (demcal fidelity)."""
        return self.dir / "fidelity.csv"

    @property
    def fidelity_figure(self) -> Path:
        """A fidelity check's figure of fine against each cheaper level."""
        return self.dir / "fidelity.png"

    @property
    def advice_dir(self) -> Path:
        """``demcal advise``'s ranking, figure and joint study files."""
        return self.dir / "advice"

    @property
    def advice(self) -> Path:
        return self.advice_dir / ADVICE_FILE

    @property
    def advice_figure(self) -> Path:
        return self.advice_dir / "advice.png"

    @property
    def early_termination(self) -> Path:
        return self.dir / "early_termination.csv"

    @property
    def live(self) -> Path:
        return self.dir / "live.html"

    @property
    def solutions(self) -> Path:
        return self.dir / SOLUTIONS_FILE

    @property
    def metamodels(self) -> Path:
        """A sampled domain's global metamodels (demcal metamodel build)."""
        return self.dir / "metamodels" / "models.pkl"

    @property
    def metamodel_validation(self) -> Path:
        """The held-out validation of a domain's metamodels (demcal metamodel validate)."""
        return self.dir / "metamodels" / "validation.html"

    def metamodel_calibration(self, kind: str) -> MetamodelCalibrationFiles:
        """A material's calibration on a domain's ``kind`` metamodels."""
        return MetamodelCalibrationFiles(self.dir / "metamodel" / kind)

    @property
    def solutions_summary(self) -> Path:
        return self.dir / "solutions.json"

    @property
    def daemon_log(self) -> Path:
        return self.dir / "daemon.log"

    @property
    def daemon_lock(self) -> Path:
        return self.dir / "daemon.lock"

    @property
    def stop_calibration(self) -> Path:
        return self.dir / "STOP_CALIBRATION"

    @property
    def logs(self) -> Path:
        return self.dir / "logs"

    @property
    def plots(self) -> Path:
        return self.dir / "plots"

    @property
    def report(self) -> Path:
        return self.dir / "report.html"

    @property
    def convergence(self) -> Path:
        return self.dir / "convergence"

    def evaluation(self, evaluation: str) -> EvaluationFiles:
        return EvaluationFiles(self.evals / evaluation)

    def evaluations(self) -> list[EvaluationFiles]:
        """The optimizer's evaluations on disk (``e0000``, ``e0001``, ...), in order."""
        return [EvaluationFiles(path) for path in sorted(self.evals.glob("e[0-9]*"))]


def evaluation_id(proposal_id: int) -> str:
    """Directory name of the optimizer's proposal ``proposal_id``."""
    return f"e{proposal_id:04d}"


def proposal_id(evaluation: str) -> int:
    return int(evaluation[1:])
