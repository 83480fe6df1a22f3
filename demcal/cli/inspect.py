"""``demcal status``, ``demcal studies`` and ``demcal watch``: the state of the studies."""

from __future__ import annotations

import argparse
import time

from demcal.cli.run import print_best
from demcal.cli.study_argument import study_of
from demcal.daemon.control import running_daemon, saved_optimizer
from demcal.errors import ConfigError, DemcalError
from demcal.reporting.terminal import NEIGHBOURS_ROLE, level_spending
from demcal.results.layout import RESULTS, STUDY_FILE
from demcal.results.records import BestRecord, FinishedRecord, Status
from demcal.study.model import Study, load_frozen

#: How ``demcal status`` words each status of the optimizer's evaluations.
STATUS_WORDS: dict[str, str] = {
    Status.OK: "ok",
    Status.FAILED: "failed",
    Status.TERMINATED: "stopped early",
    Status.PENDING: "pending",
}


def study_state(study: Study) -> tuple[str, str]:
    """Whether the study runs, ended (and why) or was interrupted; and its evaluation counts."""
    optimizer = saved_optimizer(study)
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
    confirmations = sum(r.confirms is not None for r in optimizer.records)
    extra = f", plus {confirmations} confirmation runs" if confirmations else ""
    reused, near = optimizer.reused_points, len(optimizer.neighbour_records)
    reused_text = f"; {reused} points reused from the archive" if reused else ""
    if near:
        reused_text += f"; {near} points {NEIGHBOURS_ROLE}"
    return (
        state,
        f"{line or 'no evaluations yet'} (budget {optimizer.settings.max_evaluations}{extra})"
        f"{reused_text}",
    )


def status(args: argparse.Namespace) -> int:
    study = study_of(args.config)
    if not study.files.optimizer.exists():
        print(f"demcal: study {study.name!r} has not started ({study.files.optimizer} missing)")
        return 0
    state, counts = study_state(study)
    print(f"study {study.name!r}: {state}\n  {counts}")
    spending = level_spending(study)
    if spending:
        print(f"  simulations {spending}")
    if study.files.best.exists():
        print_best(study)
    return 0


def studies(args: argparse.Namespace) -> int:
    """Every study under the results folder with its state, counts and answer."""
    found = sorted(path.parent for path in RESULTS.glob(f"*/{STUDY_FILE}"))
    if not found:
        print(f"demcal: no studies in {RESULTS}/ (a study appears there once it has run)")
        return 0
    for folder in found:
        try:
            study = load_frozen(folder / STUDY_FILE)
        except DemcalError as exc:
            print(f"{folder.name}: unreadable study.json ({exc})")
            continue
        if not study.files.optimizer.exists():
            print(f"{study.name}: not started")
            continue
        state, counts = study_state(study)
        best = BestRecord.read_if_any(study.files.best)
        print(f"{study.name}: {state}\n  {counts}{'' if best is None else answer_words(best)}")
    return 0


def answer_words(best: BestRecord) -> str:
    """The answer, ``; answer e0012 (predicted 0.42)``, and the lowest single run when it is
    another point."""
    if best.predicted_objective is None:
        words = f"; answer {best.evaluation} (objective {best.objective:.4g})"
    else:
        words = f"; answer {best.evaluation} (predicted {best.predicted_objective:.4g})"
    if best.lowest_run is not None:
        words += (
            f", lowest run {best.lowest_run['evaluation']} "
            f"(objective {best.lowest_run['objective']:.4g})"
        )
    return words


def watch(args: argparse.Namespace) -> int:
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
                    f"demcal: {study.name!r} is not running ({state}); "
                    f"the page shows its last state"
                )
                return 0
            time.sleep(args.every)
    except KeyboardInterrupt:
        return 0


def watch_arguments(sub: argparse.ArgumentParser) -> None:
    sub.add_argument(
        "--every", type=float, default=10.0, help="seconds between updates of the page (default 10)"
    )
