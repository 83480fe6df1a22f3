"""``demcal`` command line: run, status and stop a calibration.

    demcal run [CONFIG] [--profile profiles/local] [--workers N]
    demcal status [CONFIG]
    demcal studies
    demcal stop [CONFIG]
    demcal watch [CONFIG] [--every 10]
    demcal rerun-failed [CONFIG]
    demcal add-point [CONFIG] NAME=VALUE ...
    demcal solutions [CONFIG] [--k 2] [--samples 65536]
    demcal convergence [CONFIG] [--scene S] [--fractions F ...] [--sizes N ...] [--seeds 2]

CONFIG defaults to config/config.yaml. Errors in the configuration or on
disk are printed as one message (exit code 2), never as a traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import sys
import time
import traceback
from pathlib import Path

import pandas as pd

from demcal.daemon.control import add_point, lock_study, reopen_failed, request_stop, running_daemon
from demcal.daemon.launcher import SnakemakeLauncher
from demcal.daemon.loop import Calibration
from demcal.daemon.progress import ProgressDisplay
from demcal.errors import ConfigError, DemcalError
from demcal.optimizer import Optimizer
from demcal.reporting.terminal import CHOSEN_BY, confirmation_summary, evaluation_summary
from demcal.results.layout import RESULTS, StudyFiles
from demcal.results.records import BestRecord, FinishedRecord, ObjectiveRecord, Status
from demcal.study.config import load_study_file
from demcal.study.model import Study, freeze, load_frozen
from demcal.workflow import LOCAL_PROFILE, child_cores, profile_settings

DEFAULT_CONFIG = "config/config.yaml"
#: Evaluations in flight when neither the study, the command line nor the profile says.
DEFAULT_WORKERS = 2


def _workers(study: Study, profile: Path | None, given: int | None) -> int:
    """Evaluations in flight: --workers, else calibration.workers, else the profile's jobs, else 2."""
    if given is not None and given < 1:
        raise ConfigError(f"--workers {given}: give at least 1 (evaluations in flight)")
    return int(
        given
        or study.calibration.get("workers")
        or profile_settings(profile).get("jobs", DEFAULT_WORKERS)
    )


def run(args) -> int:
    with _log_file(args.log) as log:
        try:
            return _run(args, log)
        except (DemcalError, OSError) as exc:  # main() prints it; the log keeps it too
            if log is not None:
                print(f"demcal: {exc}", file=log, flush=True)
            raise


def _run(args, log) -> int:
    # the workflow hands over the study it froze (and warned about); a YAML is frozen here
    study = load_frozen(args.config) if args.frozen else load_study_file(args.config)
    profile = Path(args.profile) if args.profile else None
    lock = lock_study(study, args.watch_pid)  # noqa: F841  (held until the process ends)
    if not args.frozen:
        for warning in study.warnings:
            _say(f"demcal: warning: {warning}", log)
        study = freeze(study)  # from here on: the study as the jobs read it
    logging.basicConfig(
        filename=study.files.daemon_log,
        level=logging.INFO,
        format="%(asctime)s %(levelname)s %(message)s",
    )
    workers = _workers(study, profile, args.workers)
    launcher = SnakemakeLauncher(study.files.study, profile, child_cores(profile, workers))
    calibration = Calibration(study, launcher, workers, watch_pid=args.watch_pid)
    display = ProgressDisplay(sys.stderr, log)
    try:
        reason = calibration.run(display)
    except KeyboardInterrupt:
        display.close()
        _say(
            f"demcal: interrupted; {len(calibration.children)} evaluations keep running "
            f"and are collected by the next 'demcal run' ('demcal stop' stops them)",
            log,
        )
        return 130
    display.close()
    print(f"demcal: calibration of {study.name!r} finished: {reason}")
    print_best(study)
    return 0


@contextlib.contextmanager
def _log_file(path: str | None):
    """The --log file opened for appending (None without one)."""
    if path is None:
        yield None
        return
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a") as log:
        yield log


def _say(message: str, log=None) -> None:
    """A message on stderr, and in the log if there is one."""
    for stream in (sys.stderr, log):
        if stream is not None:
            print(message, file=stream, flush=True)


def print_best(study: Study) -> None:
    files = study.files
    if not files.best.exists():
        print(
            f"demcal: no evaluation succeeded{_commonest_failure(files)}; every reason is in "
            f"{files.evaluations_csv}"
        )
        return
    best = BestRecord.read(files.best)
    evaluation = files.evaluation(best.evaluation)
    print(
        f"best point ({CHOSEN_BY.get(best.chosen_by, 'lowest objective')} among the "
        f"evaluated points):"
    )
    print(evaluation_summary(study, ObjectiveRecord.read_latest(evaluation), evaluation.dir, best))
    if best.predicted_responses:
        print(
            "(simulated: this evaluation, ± spread of its replicates; predicted: the response models "
            "there, ± their sd; target ± its spread)"
        )
    confirmed = confirmation_summary(study, best)
    if confirmed:
        print(confirmed)
    print(f"all evaluations: {files.evaluations_csv}")


def _commonest_failure(files: StudyFiles) -> str:
    """ ", most often: REASON (n of N)" from evaluations.csv; "" when it has none."""
    try:
        reasons = pd.read_csv(files.evaluations_csv)["reason"].dropna()
    except (OSError, ValueError, KeyError):
        return ""
    if reasons.empty:
        return ""
    counts = reasons.value_counts()
    return f", most often: {counts.index[0]!r} ({counts.iloc[0]} of {len(reasons)})"


def study_of(argument: str) -> Study:
    """The study named by its YAML file or its name: as it ran (its results/<name>/study.json)
    once it has run, else as the YAML file gives it."""
    frozen = StudyFiles.of(argument).study
    if not Path(argument).is_file() and "/" not in argument and frozen.is_file():
        return load_frozen(frozen)
    study = load_study_file(argument, check_engine=False)
    return load_frozen(study.files.study) if study.files.study.is_file() else study


STATUS_WORDS = {
    Status.OK: "ok",
    Status.FAILED: "failed",
    Status.TERMINATED: "stopped early",
    Status.PENDING: "pending",
}


def study_state(study: Study) -> tuple[str, str]:
    """Whether the study runs, ended (and why) or was interrupted; and its evaluation counts."""
    optimizer = Optimizer.from_json(study.files.optimizer.read_text())
    counts = optimizer.status_counts()
    daemon = running_daemon(study)
    finished = FinishedRecord.read_if_any(study.files.finished)
    if daemon is not None:
        state = f"running (daemon pid {daemon})"
    elif finished is not None:
        state = f"ended: {finished.reason}"
    else:
        state = "not running and not finished (interrupted): 'demcal run' continues it"
    pending = counts.pop(Status.PENDING, 0)
    line = ", ".join(f"{n} {STATUS_WORDS.get(s, s)}" for s, n in sorted(counts.items()))
    if pending:
        line += f", {pending} " + (
            "running" if daemon is not None else "pending (resumed by the next run)"
        )
    confirmations = sum("confirms" in r for r in optimizer.records)
    extra = f", plus {confirmations} confirmation runs" if confirmations else ""
    return (
        state,
        f"{line or 'no evaluations yet'} (budget {optimizer.settings.max_evaluations}{extra})",
    )


def status(args) -> int:
    study = study_of(args.config)
    if not study.files.optimizer.exists():
        print(f"demcal: study {study.name!r} has not started ({study.files.optimizer} missing)")
        return 0
    state, counts = study_state(study)
    print(f"study {study.name!r}: {state}\n  {counts}")
    if study.files.best.exists():
        print_best(study)
    return 0


def studies(args) -> int:
    """Every study under the results folder with its state, counts and best objective."""
    found = sorted(path.parent for path in RESULTS.glob("*/study.json"))
    if not found:
        print(f"demcal: no studies in {RESULTS}/ (a study appears there once it has run)")
        return 0
    for folder in found:
        try:
            study = load_frozen(folder / "study.json")
        except DemcalError as exc:
            print(f"{folder.name}: unreadable study.json ({exc})")
            continue
        if not study.files.optimizer.exists():
            print(f"{study.name}: not started")
            continue
        state, counts = study_state(study)
        best = BestRecord.read_if_any(study.files.best)
        answer = "" if best is None else f"; best {best.evaluation}, objective {best.objective:.4g}"
        print(f"{study.name}: {state}\n  {counts}{answer}")
    return 0


def watch(args) -> int:
    """Keep results/<study>/live.html up to date while the calibration runs."""
    from demcal.reporting.live import write_live_page

    study = study_of(args.config)
    if not 1 <= args.every <= 3600:  # NaN fails too
        raise ConfigError(f"--every {args.every}: give 1 to 3600 s between updates")
    if not study.files.optimizer.exists():
        print(f"demcal: study {study.name!r} has not started; start it, then watch it")
        return 0
    print(
        f"demcal: live view of {study.name!r}: open {study.files.live.resolve()} in a browser "
        f"(it reloads itself every {args.every:g} s); Ctrl-C ends the watch, not the calibration"
    )
    try:
        while True:
            state, counts = study_state(study)
            write_live_page(study, state, counts, args.every)
            if running_daemon(study) is None:
                print(
                    f"demcal: {study.name!r} is not running ({state}); the page shows its last state"
                )
                return 0
            time.sleep(args.every)
    except KeyboardInterrupt:
        return 0


def stop(args) -> int:
    study = study_of(args.config)
    daemon = running_daemon(study)
    if daemon is None:
        print(f"demcal: no calibration of {study.name!r} is running; nothing to stop")
        return 0
    request_stop(study)
    print(
        f"demcal: asked the daemon of {study.name!r} (pid {daemon}) to stop: it proposes no more "
        f"points, running evaluations end as 'terminated' and it writes its tables and ends. "
        f"Everything is kept: 'demcal run' continues the calibration to its budget later "
        f"(for Snakemake, delete {study.files.finished} first)."
    )
    return 0


def add_point_command(args) -> int:
    study = study_of(args.config)
    lock = lock_study(study)  # noqa: F841  (no daemon may run meanwhile)
    evaluation = add_point(study, study.free_values(args.values, "add-point"))
    print(
        f"demcal: point {evaluation} added to study {study.name!r}; the next 'demcal run' or "
        f"'snakemake --profile ...' evaluates it (it counts towards the budget)"
    )
    return 0


def rerun_failed(args) -> int:
    study = study_of(args.config)
    lock = lock_study(study)  # noqa: F841  (no daemon may run meanwhile)
    reopened = reopen_failed(study)
    if not reopened:
        print(f"demcal: study {study.name!r} has no failed evaluations")
    else:
        print(
            f"demcal: {len(reopened)} failed evaluations ({', '.join(reopened)}) will run again "
            f"with new seeds on the next 'demcal run' or 'snakemake --profile ...'"
        )
    return 0


def solutions(args) -> int:
    from demcal.analysis.solution_report import write_solutions

    study = study_of(args.config)
    if not (args.k > 0 and args.samples >= 64):
        raise ConfigError(f"--k {args.k} must be > 0 and --samples {args.samples} at least 64")
    analysis = write_solutions(study, args.k, args.samples)
    s = analysis.solutions
    print(
        f"solution space of {study.name!r}: {len(s.points_unit)} of {s.sampled} sampled parameter sets "
        f"meet every target within {s.k:g} sd (target spread, simulation noise and model sd combined)"
    )
    for verdict in analysis.verdicts:
        print(f"  {verdict.sentence}")
    files = study.files
    print(
        f"sets: {files.solutions}; figures: {files.plots / 'solution_space.png'}, "
        f"{files.plots / 'sensitivity.png'}, {files.plots / 'objective_slices.png'}"
    )
    return 0


def convergence(args) -> int:
    from demcal import convergence as study

    study.run(
        args.config, args.scene, args.fractions, args.sizes, args.seeds, args.jobs, args.point
    )
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="demcal", description="Calibrate DEM simulations.")
    commands = parser.add_subparsers(dest="command", required=True)
    for name, func, text in (
        ("run", run, "run (or resume) a calibration"),
        ("status", status, "show the state of a calibration"),
        ("studies", studies, "list the studies in results/ with their state"),
        ("stop", stop, "stop a running calibration cleanly"),
        ("watch", watch, "a live view of a running calibration (results/<study>/live.html)"),
        (
            "add-point",
            add_point_command,
            "add a point by hand (NAME=VALUE for every free parameter)",
        ),
        ("rerun-failed", rerun_failed, "rerun the failed evaluations (new seeds) on the next run"),
        (
            "solutions",
            solutions,
            "the parameter sets that meet the targets, and which parameters the targets pin",
        ),
        (
            "convergence",
            convergence,
            "error against run time: one point at several time steps and sizes",
        ),
    ):
        sub = commands.add_parser(name, help=text)
        sub.set_defaults(func=func)
        if name == "studies":
            continue
        sub.add_argument(
            "config",
            nargs="?",
            default=DEFAULT_CONFIG,
            help="the study's YAML file"
            + ("" if name in ("run", "convergence") else ", or its name once it has run"),
        )
        if name == "run":
            sub.add_argument(
                "--profile",
                default=str(LOCAL_PROFILE),
                help="Snakemake profile directory for the evaluations "
                "(default: demcal's profiles/local)",
            )
            sub.add_argument("--workers", type=int, help="evaluations in flight")
            # set by the workflow's calibrate rule: the daemon ends with its Snakemake, and
            # it is handed the frozen study.json instead of the YAML
            sub.add_argument("--watch-pid", type=int, help=argparse.SUPPRESS)
            sub.add_argument("--frozen", action="store_true", help=argparse.SUPPRESS)
            sub.add_argument(
                "--log", help="also append the messages and a progress line every 30 s to this file"
            )
        if name == "watch":
            sub.add_argument(
                "--every",
                type=float,
                default=10.0,
                help="seconds between updates of the page (default 10)",
            )
        if name == "add-point":
            sub.add_argument("values", nargs="+", metavar="NAME=VALUE")
        if name == "solutions":
            sub.add_argument(
                "--k",
                type=float,
                default=2.0,
                help="tolerance in combined standard deviations (default 2)",
            )
            sub.add_argument(
                "--samples",
                type=int,
                default=2**16,
                help="Sobol points sampled over the box (default 65536)",
            )
        if name == "convergence":
            sub.add_argument("--scene", help="default: the study's first scene")
            sub.add_argument(
                "--fractions",
                type=float,
                nargs="+",
                help="time steps as fractions of the Rayleigh time (default 0.5 0.35 0.25 0.125)",
            )
            sub.add_argument(
                "--sizes",
                type=float,
                nargs="+",
                help="values of the scene's size setting (particle count or box "
                "scale; default 0.5, 1 and 2 times the configured one)",
            )
            sub.add_argument("--seeds", type=int, default=2, help="seeds per variant")
            sub.add_argument(
                "--jobs", type=int, default=os.cpu_count() or 1, help="simulations at a time"
            )
            sub.add_argument(
                "--point",
                nargs="*",
                default=[],
                metavar="NAME=VALUE",
                help="free parameter values (default: centre of the bounds)",
            )
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except DemcalError as exc:
        print(f"demcal: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # full disk, permissions: finished evaluations stay on disk
        print(
            f"demcal: {exc}; fix it and run the same command again (finished evaluations are kept)",
            file=sys.stderr,
        )
        return 2
    except Exception as exc:  # a bug: say where the details are, keep the terminal clean
        logs = [
            h.baseFilename
            for h in logging.getLogger().handlers
            if isinstance(h, logging.FileHandler) and h.baseFilename != os.devnull
        ]
        if logs:
            logging.getLogger("demcal").exception("internal error")
            where = f"traceback in {logs[0]}"
        else:  # before the study's log exists: the traceback is all there is to report
            traceback.print_exc()
            where = "traceback above"
        print(
            f"demcal: internal error: {type(exc).__name__}: {exc} ({where}; please report it)",
            file=sys.stderr,
        )
        return 3


if __name__ == "__main__":
    sys.exit(main())
