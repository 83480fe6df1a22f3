"""demcal from Python, for notebooks: open a study's results, load and run a study file.

```python
import demcal

results = demcal.open("results/quickstart")  # or demcal.open("quickstart")
results.evaluations  # a pandas DataFrame, units in .attrs["units"]
results.answer  # the answer (None before any evaluation succeeded); .to_frame()
results.plot_optimization_history()  # a matplotlib Figure, as in the report
results.solutions()  # the parameter sets that meet the targets; .points(), .posterior

study = demcal.load("config/examples/analytic.yaml")  # validated as `demcal run` does
study.parameters, study.targets  # the free parameters with bounds, the targets
results = study.run(workers=2)  # calibrates as `demcal run` does, then opens its results
```

Errors are ``DemcalError``s whose message is meant for the user as it stands:
a study file's are ``ConfigError``s that name the field, as on the command
line. ``results/`` is relative to the working directory, as for the
``demcal`` command: a notebook runs its studies in the folder it was started
in, unless it changes folder.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import numbers
import operator
import os
import reprlib
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, SupportsIndex

import pandas as pd

from demcal.analysis.solutions import SOLUTION_SAMPLES
from demcal.daemon.tables import evaluation_columns
from demcal.errors import ConfigError, DemcalError, bounded_reason
from demcal.reporting.terminal import ANSWER_VERSUS_LOWEST_RUN, CHOSEN_BY
from demcal.results.layout import RESULTS, StudyFiles
from demcal.results.records import BestRecord, FinishedRecord
from demcal.study.config import load_study_file
from demcal.study.model import Study, load_frozen

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from demcal.analysis.solution_report import SolutionAnalysis
    from demcal.analysis.solutions import Verdict
    from demcal.optimizer import Optimizer

__all__ = ["Answer", "LowestRun", "Results", "Solutions", "StudyFile", "load", "open"]

#: The columns of evaluations.csv that hold times (ISO 8601 in UTC).
TIME_COLUMNS = ("started_at", "ended_at")


@dataclass
class _StudyIn(Study):
    """A frozen study whose results folder is ``folder``, wherever it lies (``Study.files``
    is ``results/<name>`` under the working directory)."""

    folder: Path = RESULTS

    @property
    def files(self) -> StudyFiles:
        return StudyFiles(self.folder)


def _path_argument(value: object, argument: str, allowed: str) -> Path:
    """The path a caller gave as ``argument`` (a str, bytes or os.PathLike); a ConfigError
    naming the argument and ``allowed`` for anything else, an empty path or one with a NUL."""
    try:
        text = os.fsdecode(value)  # type: ignore[arg-type]
    except TypeError:
        raise ConfigError(
            f"{argument} is {reprlib.repr(value)} ({type(value).__name__}); give {allowed}"
        ) from None
    if not text or "\0" in text:
        raise ConfigError(f"{argument} is {reprlib.repr(text)}, not a path; give {allowed}")
    return Path(text)


def _whole_number(value: object, argument: str, low: int, high: float = math.inf) -> int:
    """``value`` if it is a whole number from ``low`` to ``high``, else a ConfigError naming
    ``argument`` and the range."""
    if isinstance(value, bool) or not isinstance(value, SupportsIndex):  # 2.0, "2", True
        number = low - 1
    else:  # int, NumPy's integers
        number = operator.index(value)
    if not low <= number <= high:
        upto = f"from {low} to {high}" if high < math.inf else f"of {low} or more"
        raise ConfigError(f"{argument} is {reprlib.repr(value)}; give a whole number {upto}")
    return number


def _column_units(study: Study) -> dict[str, str]:
    """The unit of every column of evaluations.csv, by column (free parameters, responses)."""
    return {column: unit for column, unit, _ in evaluation_columns(study)}


def _with_unit(name: str, unit: str | None) -> str:
    """A column's name with its unit, as ``bulk_density [kg/m^3]`` (the name alone without one)."""
    return f"{name} [{unit}]" if unit else name


#: What demcal.open takes.
OPEN_TAKES = "a results folder (a str or Path such as 'results/quickstart') or a study's name"


def _results_folder(where: object) -> Path:
    """The folder ``where`` names: itself, else ``results/<where>`` for a study's name."""
    path = _path_argument(where, "demcal.open: where", OPEN_TAKES)
    try:
        if path.is_dir():
            return path
        if path.exists():
            raise DemcalError(
                f"{path} is a file, not a results folder (a study's results are in "
                f"results/<study>/; demcal.load() reads a study file)"
            )
        if len(path.parts) == 1:  # a study's name
            named = StudyFiles.of(path.name).dir
            if named.is_dir():
                return named
            raise DemcalError(f"no results folder {path} nor {named}: the study has not run here")
    except OSError as exc:  # a name too long for the file system, a folder it may not read
        raise ConfigError(
            f"demcal.open: where is {reprlib.repr(str(path))}: {exc.strerror or exc}; give "
            f"{OPEN_TAKES}"
        ) from None
    raise DemcalError(f"no results folder {path}: the study has not run here")


def open(where: str | Path) -> Results:
    """The results of a calibration: its folder, or a study's name under ``results/``.

    Args:
        where: ``results/<study>`` (any path to such a folder) or the study's name.

    Returns:
        The study's results, read from disk whenever an attribute is read.

    Raises:
        ConfigError: ``where`` is not a path or a name (None, a number, an empty string).
        DemcalError: the folder does not exist, or it is not a demcal results folder
            (it has no ``study.json``); the message names the path and what is missing.
    """
    folder = _results_folder(where).resolve()
    frozen = StudyFiles(folder).study
    if not frozen.is_file():
        raise DemcalError(
            f"{folder} is not the results folder of a demcal study: {frozen.name} is "
            f"missing (a calibration writes it when it starts)"
        )
    study = load_frozen(frozen)
    fields = {f.name: getattr(study, f.name) for f in dataclasses.fields(study)}
    return Results(_StudyIn(**fields, folder=folder))


@dataclass(frozen=True, repr=False)
class Results:
    """The results of one study on disk (``results/<study>/``), as a notebook reads them.

    ``study`` is the frozen study (``study.json``) the calibration ran, with
    ``study.files`` the paths of this folder. Every other attribute is read from the
    files when it is asked for, so a calibration still running shows its progress.
    """

    study: Study

    @property
    def files(self) -> StudyFiles:
        """The paths of the results files ([`StudyFiles`][demcal.results.layout.StudyFiles])."""
        return self.study.files

    @property
    def evaluations(self) -> pd.DataFrame:
        """``evaluations.csv``: one row per evaluation (parameters, responses per replicate,
        objective, status, times, cost).

        ``attrs["units"]`` maps each column to its unit (``evaluations.columns.csv``);
        ``started_at`` and ``ended_at`` are datetimes in UTC (NaT while unknown).
        """
        files = self.files
        with _damaged(self._evaluations_file()):
            table = pd.read_csv(files.evaluations_csv)
            for column in TIME_COLUMNS:
                table[column] = pd.to_datetime(table[column], utc=True)
        if files.evaluations_columns.is_file():
            with _damaged(files.evaluations_columns):
                columns = pd.read_csv(files.evaluations_columns, dtype=str, keep_default_na=False)
                units = dict(zip(columns["column"], columns["unit"]))
        else:  # a folder written before the sidecar existed: the study's own columns
            units = _column_units(self.study)
        table.attrs["units"] = units
        return table

    def _evaluations_file(self) -> Path:
        """``evaluations.csv``; a DemcalError if the study has none yet."""
        path = self.files.evaluations_csv
        if not path.is_file():
            raise DemcalError(
                f"{path} is missing: study {self.study.name!r} has no evaluations yet"
            )
        return path

    @property
    def answer(self) -> Answer | None:
        """The calibration's answer so far (``best.json``): the evaluated point whose
        objective the response models of all runs predict lowest; None while no evaluation
        has succeeded. It need not be the lowest single run
        ([`lowest_run`][demcal.api.Results.lowest_run])."""
        best = self._best_record()
        return None if best is None else Answer(best, self.study)

    @property
    def best(self) -> Answer | None:
        """The same as [`answer`][demcal.api.Results.answer] (its earlier name)."""
        return self.answer

    @property
    def lowest_run(self) -> LowestRun | None:
        """The evaluation whose own runs scored the lowest objective, when it is not the
        answer; None when the answer is that evaluation too (or none has succeeded)."""
        best = self._best_record()
        if best is None or best.lowest_run is None:
            return None
        return LowestRun(
            self.study.name,
            best.lowest_run["evaluation"],
            best.lowest_run["objective"],
            best.evaluation,
        )

    def _best_record(self) -> BestRecord | None:
        return BestRecord.read(self.files.best) if self.files.best.exists() else None

    @property
    def finished(self) -> FinishedRecord | None:
        """Why the calibration ended (``finished.json``); None while it runs or was
        interrupted."""
        files = self.files
        return FinishedRecord.read(files.finished) if files.finished.exists() else None

    @property
    def optimizer(self) -> Optimizer:
        """The optimizer as the calibration left it (``optimizer.json``); its ask/tell is
        public ([`demcal.optimizer`][demcal.optimizer])."""
        from demcal.daemon.control import saved_optimizer

        return saved_optimizer(self.study)

    @property
    def figures(self) -> dict[str, Path]:
        """The figures in ``plots/`` by name (``objective_vs_evaluation``, ...): those of the
        report (``snakemake``), of ``demcal solutions`` and of
        [`draw_figures`][demcal.api.Results.draw_figures]."""
        return {path.stem: path for path in sorted(self.files.plots.glob("*.png"))}

    def draw_figures(self) -> dict[str, Path]:
        """Write the report's figures of the calibration into ``plots/`` as PNG files
        (``demcal run`` alone makes none); returns [`figures`][demcal.api.Results.figures].
        The ``plot_*`` methods draw the same figures in the notebook."""
        from demcal.reporting.figures import write_plots

        write_plots(self.study, self.files.plots)
        return self.figures

    def _figure_table(self) -> pd.DataFrame:
        """The evaluations as the figures draw them (``load_table``)."""
        from demcal.reporting.figures import load_table

        self._evaluations_file()
        return load_table(self.study)

    def plot_optimization_history(self) -> Figure:
        """The objective of every evaluation against its number, with the best so far (the
        report's ``objective_vs_evaluation``)."""
        from demcal.reporting.figures import plot_objective_vs_evaluation

        return plot_objective_vs_evaluation(self.study, self._figure_table())

    def plot_objective_vs_time(self) -> Figure:
        """The objective against wall-clock time and against the simulations' CPU time (the
        report's ``objective_vs_time``)."""
        from demcal.reporting.figures import plot_objective_vs_time

        return plot_objective_vs_time(self.study, self._figure_table())

    def plot_parameter_traces(self) -> Figure:
        """Each free parameter against the evaluation number within its bounds, the answer's
        value as a line (the report's ``parameter_traces``)."""
        from demcal.reporting.figures import plot_parameter_traces

        return plot_parameter_traces(self.study, self._figure_table(), self._best_record())

    def plot_responses(self) -> Figure:
        """Each targeted response against the evaluation number, with its target and the
        answer (the report's ``responses_vs_targets``)."""
        from demcal.reporting.figures import plot_responses_vs_targets

        return plot_responses_vs_targets(self.study, self._figure_table(), self._best_record())

    def plot_parallel_coordinate(self) -> Figure:
        """Every finished evaluation as a line across the free parameters, coloured by its
        objective (the report's ``parallel_coordinates``)."""
        from demcal.reporting.figures import plot_parallel_coordinates

        return plot_parallel_coordinates(self.study, self._figure_table(), self._best_record())

    def plot_early_termination(self) -> Figure:
        """The objective estimates of running evaluations over time against the limit each
        was held to (the report's ``early_termination``)."""
        from demcal.reporting.figures import (
            evaluation_statuses,
            load_estimates,
            plot_early_termination,
        )

        statuses = evaluation_statuses(self._figure_table())
        return plot_early_termination(self.study, load_estimates(self.study), statuses)

    def plot_answer_history(self) -> Figure:
        """The answer's responses over simulated time, mean and ±1 sd over its runs, from the
        scenes that keep a time series (the report's ``answer_history``)."""
        from demcal.reporting.figures import plot_answer_history

        return plot_answer_history(self.study, self._best_record())

    def solutions(self, k: float = 2.0, samples: int = 2**16, seed: int = 0) -> Solutions:
        """The solution space, as ``demcal solutions`` finds it (without writing files).

        Args:
            k: tolerance in combined standard deviations (each target's standard error and
                model discrepancy, demcal.optimizer.membership.band_sd).
            samples: Sobol points sampled over the parameter box (64 to 2**20).
            seed: seed of the sampling.

        Returns:
            The accepted parameter sets (``.points()``, ``.to_frame()``), the verdict per
                parameter (``.verdicts``), the Sobol indices (``.sensitivity``), the
                posterior sample (``.posterior``) and their figures.
        """
        from demcal.analysis.solution_report import analyse

        given: object = k  # whatever the caller passed
        if isinstance(given, bool) or not isinstance(given, numbers.Real) or not 0 < k < math.inf:
            raise ConfigError(
                f"solutions: k is {reprlib.repr(k)}; give a number of standard deviations above 0"
            )
        samples = _whole_number(samples, "solutions: samples", *SOLUTION_SAMPLES)
        seed = _whole_number(seed, "solutions: seed", 0)
        return Solutions(analyse(self.study, float(k), samples, seed), self.study, seed)

    def __repr__(self) -> str:
        finished = self.finished
        state = "not finished" if finished is None else f"finished: {finished.reason}"
        best = self._best_record()
        answer = (
            "no answer yet"
            if best is None
            else f"answer {best.evaluation}, objective {best.objective:.4g} (see .answer)"
        )
        return f"<demcal results of {self.study.name!r} in {self.files.dir} ({state}; {answer})>"


@dataclass(frozen=True, repr=False)
class Answer:
    """The calibration's answer (``best.json``) and the study it answers.

    Every field of the record reads through: ``evaluation``, ``parameters``,
    ``objective`` (of the answer's own runs), ``predicted_objective`` (of the
    response models there), ``responses``, ``predicted_responses``, ``targets``,
    ``units``, ... (``record`` is the [`BestRecord`][demcal.results.records.BestRecord]).
    """

    record: BestRecord
    study: Study

    def __getattr__(self, name: str) -> Any:
        if name in {f.name for f in dataclasses.fields(BestRecord)}:
            return getattr(self.record, name)
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def to_frame(self) -> pd.DataFrame:
        """The answer against the targets, a row per quantity (each free parameter, each
        targeted response, the objective): ``value`` (simulated), ``predicted`` and
        ``predicted_sd`` (the response models), ``target``, ``target_spread``,
        ``relative_error_percent``, ``unit`` and ``note`` (a parameter on a bound)."""
        from demcal.reporting.figures import answer_table

        return answer_table(self.study, self.record).set_index("quantity")

    def __repr__(self) -> str:
        best = self.record
        chosen = CHOSEN_BY.get(best.chosen_by or "", "lowest objective")
        values = ", ".join(
            f"{p.name} = {best.parameters[p.name]:.4g} [{p.spec.unit}]" for p in self.study.free
        )
        predicted = (
            ""
            if best.predicted_objective is None
            else f"{best.predicted_objective:.4g} predicted, "
        )
        lines = [
            f"<demcal answer of {self.study.name!r}: evaluation {best.evaluation} ({chosen})",
            f"  {values}",
            f"  objective {predicted}{best.objective:.4g} observed in its own runs",
        ]
        if best.lowest_run is not None:
            lines.append(
                f"  not the lowest single run ({best.lowest_run['evaluation']}, see .lowest_run)"
            )
        return "\n".join(lines) + ">"


@dataclass(frozen=True, repr=False)
class LowestRun:
    """The evaluation whose own runs scored the lowest objective, where it is not the answer:
    one run scatters with the simulation's noise, so it may have been lucky."""

    study: str
    evaluation: str
    objective: float
    answer: str

    def __repr__(self) -> str:
        return (
            f"<demcal lowest single run of {self.study!r}: evaluation {self.evaluation}, "
            f"objective {self.objective:.4g} observed; not the answer ({self.answer}): "
            f"{ANSWER_VERSUS_LOWEST_RUN}>"
        )


@dataclass(frozen=True, repr=False)
class Solutions:
    """The solution space of a study ([`Results.solutions`][demcal.api.Results.solutions]):
    the parameter sets whose predicted responses may meet every target, what they say of
    each parameter, the sensitivities and the posterior, with their figures.

    ``analysis`` is the analysis as ``demcal solutions`` computes it (arrays in the unit
    box, the Sobol indices as rows) with the ``seed`` it sampled with; the views below name
    every column, with its unit.
    """

    analysis: SolutionAnalysis
    study: Study
    seed: int

    @property
    def verdicts(self) -> list[Verdict]:
        """A [`Verdict`][demcal.analysis.solutions.Verdict] per free parameter
        (``.sentence`` says it in words)."""
        return self.analysis.verdicts

    def _parameter_columns(self) -> list[str]:
        return [_with_unit(p.name, p.spec.unit) for p in self.study.free]

    def points(self) -> pd.DataFrame:
        """The parameter sets the response models cannot rule out, a row each, a column per
        free parameter (``name [unit]``)."""
        return pd.DataFrame(self.analysis.points(), columns=self._parameter_columns())

    def to_frame(self) -> pd.DataFrame:
        """[`points`][demcal.api.Solutions.points] with each set's
        ``membership_probability`` (that every response meets its target) and each
        response's predicted mean and sd there (``key predicted [unit]``, ``key sd [unit]``),
        as ``solutions.csv`` holds them."""
        from demcal.analysis.solution_report import solutions_table

        units = _column_units(self.study)

        def named(column: str) -> str:
            key, _, what = column.rpartition(" ")
            return _with_unit(column, units.get(key if what in ("predicted", "sd") else column))

        return solutions_table(self.analysis).rename(columns=named)

    @property
    def sensitivity(self) -> pd.DataFrame:
        """The total Sobol index of each response (column) to each free parameter (row): the
        share of the response's variance over the box that the parameter causes, alone and
        with others."""
        rows = pd.DataFrame(self.analysis.sensitivity)
        return rows.pivot(index="parameter", columns="response", values="ST").reindex(
            index=self.analysis.names, columns=list(dict.fromkeys(rows["response"]))
        )

    @property
    def posterior(self) -> pd.DataFrame:
        """The posterior of the parameters as a weighted sample: every Sobol point of the box
        (a column per free parameter, ``name [unit]``) with its ``weight`` (the likelihood of
        the targets there under a uniform prior, the weights summing to 1)."""
        posterior = self.analysis.solutions.posterior
        table = pd.DataFrame(
            self.analysis.in_real_units(posterior.points_unit), columns=self._parameter_columns()
        )
        table["weight"] = posterior.weights
        return table

    @property
    def effective_samples(self) -> float:
        """Kish's effective sample size of the posterior's weights (few: it is rough)."""
        return self.analysis.solutions.posterior.effective_samples

    def _answer_point(self) -> dict[str, dict[str, float]] | None:
        """The answer's parameters, marked in the figures (None without an answer)."""
        best = BestRecord.read_if_any(self.study.files.best)
        return None if best is None else {"parameters": best.parameters}

    def plot_solutions(self) -> Figure:
        """Pairwise scatter of the parameter sets and a histogram per parameter, coloured by
        how sure their membership is, the answer in red (``solution_space.png``)."""
        from demcal.analysis.solution_report import plot_corner

        return plot_corner(self.analysis, self._answer_point(), seed=self.seed)

    def plot_sensitivity(self) -> Figure:
        """The total and first-order Sobol index of each parameter, a panel per response
        (``sensitivity.png``)."""
        from demcal.analysis.solution_report import plot_sensitivity

        return plot_sensitivity(self.analysis.sensitivity)

    def plot_contour(self) -> Figure:
        """The predicted objective over pairs of the most influential parameters, the others
        held at the answer (``objective_slices.png``)."""
        from demcal.analysis.solution_report import plot_objective_slices

        return plot_objective_slices(self.analysis, self._answer_point())

    def __repr__(self) -> str:
        s = self.analysis.solutions
        lines = [
            f"<demcal solution space of {self.study.name!r}: of {s.sampled} sampled parameter "
            f"sets, {int(s.likely.sum())} are likely to meet every target within {s.k:g} sd and "
            f"{len(s.points_unit)} cannot be ruled out; posterior of "
            f"{s.posterior.effective_samples:.0f} effective samples"
        ]
        for v in self.analysis.verdicts:
            span = (
                ""
                if math.isnan(v.low)
                else f", {v.low:.3g}–{v.high:.3g} of {v.lower:g}–{v.upper:g}"
            )
            lines.append(f"  {_with_unit(v.name, v.unit)}: {v.verdict}{span}")
        return "\n".join(lines) + ">"


def load(path: str | Path) -> StudyFile:
    """A study file, validated as ``demcal run`` validates it.

    Args:
        path: the study's YAML file.

    Returns:
        Its facts (name, free parameters, targets) and
            [`StudyFile.run`][demcal.api.StudyFile.run].

    Raises:
        ConfigError: ``path`` is not a path (None, a dict, an empty string), or the file is
            missing or invalid; the message names the field, its value and what is allowed.
    """
    where = _path_argument(path, "demcal.load: path", "the study's YAML file (a str or Path)")
    return StudyFile(where, load_study_file(where))


@dataclass(frozen=True, repr=False)
class StudyFile:
    """A validated study file: what it calibrates, and [`run`][demcal.api.StudyFile.run]
    to calibrate it.

    ``path`` is the YAML file, ``study`` the study as the file gives it, every default
    filled in (frozen only when it runs).
    """

    path: Path
    study: Study

    @property
    def name(self) -> str:
        return self.study.name

    @property
    def parameters(self) -> pd.DataFrame:
        """The free parameters: ``lower`` and ``upper`` bound and ``unit``, by name."""
        return pd.DataFrame(
            [(p.name, p.lower, p.upper, p.spec.unit) for p in self.study.free],
            columns=["parameter", "lower", "upper", "unit"],
        ).set_index("parameter")

    @property
    def targets(self) -> pd.DataFrame:
        """The targets: scene, response, ``value``, ``unit``, ``weight``, ``spread`` (the sd of
        single lab tests, None if not given), ``tests`` (how many the value is the mean of),
        ``discrepancy`` (the model discrepancy's sd) and the bounds ``at_least`` and
        ``at_most`` of a target kept within them (None if it has none), by
        ``scene.response``."""
        study = self.study
        return pd.DataFrame(
            [
                (
                    t.key,
                    t.scene,
                    t.response,
                    t.value,
                    study.scenes[t.scene].responses[t.response].unit,
                    t.weight,
                    t.spread,
                    t.tests,
                    t.discrepancy,
                    t.lower,
                    t.upper,
                )
                for t in study.targets
            ],
            columns=[
                "target",
                "scene",
                "response",
                "value",
                "unit",
                "weight",
                "spread",
                "tests",
                "discrepancy",
                "at_least",
                "at_most",
            ],
        ).set_index("target")

    @property
    def warnings(self) -> list[str]:
        """What the validation warned about (said again on stderr by
        [`run`][demcal.api.StudyFile.run])."""
        return list(self.study.warnings)

    def run(self, workers: int | None = None, profile: str | Path | None = None) -> Results:
        """Calibrate the study as ``demcal run`` does, or resume its calibration.

        The file is read again, checked against an earlier calibration of the same study
        (``results/<study>/study.json``), frozen, and calibrated under the study's lock, one
        child Snakemake per evaluation. The progress goes to stderr. An interrupt stops
        waiting; the running evaluations go on and the next run collects them.

        Args:
            workers: evaluations in flight (default: the study's ``calibration.workers``,
                else the profile's ``jobs``, else 2).
            profile: the Snakemake profile of the evaluations (default: demcal's
                ``profiles/local``).

        Returns:
            The calibration's results ([`open`][demcal.api.open]).
        """
        import sys

        from demcal.daemon.session import calibrate, locked_study
        from demcal.snakemake_command import LOCAL_PROFILE

        if workers is not None:
            workers = _whole_number(workers, "run: workers", 1)
        chosen = (
            LOCAL_PROFILE
            if profile is None
            else _path_argument(profile, "run: profile", "a Snakemake profile's folder")
        )
        with locked_study(self.path) as study, _daemon_log(study):
            reason = calibrate(study, chosen, workers)
        print(f"demcal: calibration of {study.name!r} finished: {reason}", file=sys.stderr)
        return open(study.files.dir)

    def __repr__(self) -> str:
        free, targets = len(self.study.free), len(self.study.targets)
        return (
            f"<demcal study {self.name!r} from {self.path}: {free} free parameters, "
            f"{targets} targets>"
        )


@contextlib.contextmanager
def _damaged(path: Path) -> Iterator[None]:
    """Reading the table ``path`` in the block: a file that is not the table demcal wrote (not
    UTF-8, not CSV, a column missing) ends as a DemcalError naming it."""
    try:
        yield
    except (OSError, ValueError, KeyError) as exc:
        raise DemcalError(
            f"{path}: not the table demcal writes ({type(exc).__name__}: "
            f"{bounded_reason(str(exc))}); the file is damaged"
        ) from None


@contextlib.contextmanager
def _daemon_log(study: Study) -> Iterator[None]:
    """The calibration's log messages in its ``daemon.log`` while the block runs (the
    ``demcal`` command sets this up once per process; a notebook may run several studies)."""
    from demcal.daemon.session import DAEMON_LOG_FORMAT

    logger = logging.getLogger("demcal")
    handler = logging.FileHandler(study.files.daemon_log)
    handler.setFormatter(logging.Formatter(DAEMON_LOG_FORMAT))
    level = logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    try:
        yield
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)
        handler.close()
