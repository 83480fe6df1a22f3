"""``demcal stop``, ``demcal add-point`` and ``demcal rerun-failed``: steer a study."""

from __future__ import annotations

import argparse

from demcal.cli.options import ASSIGNMENT
from demcal.cli.study_argument import study_of
from demcal.daemon.control import add_point, lock_study, reopen_failed, request_stop, running_daemon


def stop(args: argparse.Namespace) -> int:
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


def add_point_command(args: argparse.Namespace) -> int:
    study = study_of(args.config)
    lock = lock_study(study)  # noqa: F841  (no daemon may run meanwhile)
    evaluation = add_point(study, study.free_values(args.values, "add-point"))
    print(
        f"demcal: point {evaluation} added to study {study.name!r}; the next 'demcal run' or "
        f"'snakemake --profile ...' evaluates it (it counts towards the budget)"
    )
    return 0


def rerun_failed(args: argparse.Namespace) -> int:
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


def add_point_arguments(sub: argparse.ArgumentParser) -> None:
    sub.add_argument("values", nargs="+", metavar=ASSIGNMENT)
