"""``demcal`` command line: run, status and stop a calibration.

    demcal run [CONFIG] [--profile profiles/local] [--workers N]
    demcal status [CONFIG]
    demcal studies
    demcal stop [CONFIG]
    demcal watch [CONFIG] [--every 10]
    demcal rerun-failed [CONFIG]
    demcal add-point [CONFIG] NAME=VALUE ...
    demcal solutions [CONFIG] [--k 2] [--samples 65536] [--explore N] [--point NAME=VALUE ...]
    demcal convergence [CONFIG] [--scene S] [--fractions F ...] [--sizes N ...] [--seeds 2]
    demcal psd fit SIEVE.csv
    demcal sample [CONFIG] --n N [--design fssf_f] [--name STUDY] [--profile profiles/local]
    demcal metamodel build|validate|show [CONFIG] [--model kriging symbolic] [--holdout STUDY]
    demcal calibrate-metamodel [MATERIAL] --domain CONFIG [--model kriging] [--validate N]
    demcal archive list|show|export|import|stats [--url URL | --study CONFIG]

CONFIG defaults to config/config.yaml. Errors in the configuration or on
disk are printed as one message (exit code 2), never as a traceback; so are
mistakes on the command line (:class:`Parser`).

This module holds the parser and ``main``; the commands live in ``run.py``
(run, the best point), ``inspect.py`` (status, studies, watch), ``manage.py``
(stop, add-point, rerun-failed), ``analysis.py`` (solutions, convergence), ``psd.py``
(fits to sieve data), ``archive.py`` (the archive of simulations), ``sample.py``
(sampling campaigns) and ``metamodel.py`` (global metamodels of a domain);
``options.py`` checks the numbers that options take.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import traceback
from collections.abc import Callable, Sequence
from typing import NoReturn

from demcal.api import SOLUTION_SAMPLES
from demcal.cli import analysis, archive, inspect, manage, metamodel, psd, run, sample
from demcal.cli.options import MOST_SIMULATIONS, whole_number
from demcal.errors import DemcalError
from demcal.resources import DEFAULT_CONFIG
from demcal.workflow import LOCAL_PROFILE


def run_arguments(sub: argparse.ArgumentParser) -> None:
    sub.add_argument(
        "--profile",
        default=str(LOCAL_PROFILE),
        help="Snakemake profile directory for the evaluations (default: demcal's profiles/local)",
    )
    sub.add_argument("--workers", type=int, help="evaluations in flight")
    # set by the workflow's calibrate rule: the daemon ends with its Snakemake
    sub.add_argument("--watch-pid", type=int, help=argparse.SUPPRESS)
    # set by the calibrate rule too: the config is the study.json it froze
    sub.add_argument("--frozen", action="store_true", help=argparse.SUPPRESS)
    sub.add_argument(
        "--log", help="also append the messages and a progress line every 30 s to this file"
    )


def watch_arguments(sub: argparse.ArgumentParser) -> None:
    sub.add_argument(
        "--every", type=float, default=10.0, help="seconds between updates of the page (default 10)"
    )


def add_point_arguments(sub: argparse.ArgumentParser) -> None:
    sub.add_argument("values", nargs="+", metavar="NAME=VALUE")


def solutions_arguments(sub: argparse.ArgumentParser) -> None:
    sub.add_argument(
        "--k",
        type=float,
        default=2.0,
        help="tolerance in combined standard deviations (default 2)",
    )
    sub.add_argument(
        "--samples",
        type=whole_number(*SOLUTION_SAMPLES),
        default=2**16,
        help=f"Sobol points sampled over the box, {SOLUTION_SAMPLES[0]} to "
        f"{SOLUTION_SAMPLES[1]} (default 65536)",
    )
    sub.add_argument(
        "--point",
        nargs="+",
        metavar="NAME=VALUE",
        help="judge one parameter set (every free parameter, once) against the targets",
    )
    sub.add_argument(
        "--explore",
        type=whole_number(1, MOST_SIMULATIONS),
        metavar="N",
        help="queue N simulations where membership in the solution set is least certain, "
        f"for the next run (1 to {MOST_SIMULATIONS})",
    )


#: The most seeds per variant, and simulations at a time, of ``demcal convergence``.
MOST_SEEDS = 100
MOST_JOBS = 1024


def convergence_arguments(sub: argparse.ArgumentParser) -> None:
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
    sub.add_argument(
        "--seeds",
        type=whole_number(1, MOST_SEEDS),
        default=2,
        help=f"seeds per variant, 1 to {MOST_SEEDS}",
    )
    sub.add_argument(
        "--jobs",
        type=whole_number(1, MOST_JOBS),
        default=os.cpu_count() or 1,
        help=f"simulations at a time, 1 to {MOST_JOBS}",
    )
    sub.add_argument(
        "--point",
        nargs="*",
        default=[],
        metavar="NAME=VALUE",
        help="free parameter values (default: centre of the bounds)",
    )


Command = Callable[[argparse.Namespace], int]
Arguments = Callable[[argparse.ArgumentParser], None] | None

#: Every command: its name, what it does, the function that runs it and its own options.
COMMANDS: tuple[tuple[str, str, Command, Arguments], ...] = (
    ("run", "run (or resume) a calibration", run.run, run_arguments),
    ("status", "show the state of a calibration", inspect.status, None),
    ("studies", "list the studies in results/ with their state", inspect.studies, None),
    ("stop", "stop a running calibration cleanly", manage.stop, None),
    (
        "watch",
        "a live view of a running calibration (results/<study>/live.html)",
        inspect.watch,
        watch_arguments,
    ),
    (
        "add-point",
        "add a point by hand (NAME=VALUE for every free parameter)",
        manage.add_point_command,
        add_point_arguments,
    ),
    (
        "rerun-failed",
        "rerun the failed evaluations (new seeds) on the next run",
        manage.rerun_failed,
        None,
    ),
    (
        "solutions",
        "the parameter sets that meet the targets, and which parameters the targets pin",
        analysis.solutions,
        solutions_arguments,
    ),
    (
        "convergence",
        "error against run time: one point at several time steps and sizes",
        analysis.convergence,
        convergence_arguments,
    ),
    (
        "psd",
        "particle-size distribution: psd fit SIEVE.csv fits GGS, RRSB and LOGN to sieve data",
        psd.psd,
        psd.arguments,
    ),
    (
        "sample",
        "a sampling campaign: a space-filling design over the study's box, into the archive",
        sample.sample,
        sample.arguments,
    ),
    (
        "metamodel",
        "global metamodels of a sampled domain: build, validate (held-out R²), show",
        metamodel.metamodel_command,
        metamodel.arguments,
    ),
    (
        "calibrate-metamodel",
        "calibrate a material on a domain's metamodels, no simulation (then --validate N)",
        metamodel.calibrate_command,
        metamodel.calibrate_arguments,
    ),
    (
        "archive",
        "the archive of every simulation: list, show, export, import, stats",
        archive.archive,
        archive.arguments,
    ),
)

#: Commands that take no study file first (they work on every study, on the archive or on other
#: input, or take an action before it).
WITHOUT_CONFIG = ("studies", "archive", "psd", "metamodel")


class Parser(argparse.ArgumentParser):
    """demcal's argument parser: a usage error is one line, ``demcal: ...``, that names the
    command, the option and what is wrong with it (exit code 2)."""

    def error(self, message: str) -> NoReturn:
        command = self.prog.removeprefix("demcal").strip()  # "", "run", "archive list"
        where = f"{command}: " if command else ""
        text = " ".join(message.removeprefix("argument ").split())  # one line whatever the words
        self.exit(2, f"demcal: {where}{text}; '{self.prog} --help' shows the options\n")

    def parse_known_args(  # type: ignore[override]
        self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None
    ) -> tuple[argparse.Namespace, list[str]]:
        """Each parser, a command's too, refuses the words it does not know itself: the
        message then names the command whose options they are not."""
        parsed, extra = super().parse_known_args(args, namespace)
        if extra:
            self.error(f"unrecognized arguments: {' '.join(extra)}")
        return parsed, extra


def parser() -> argparse.ArgumentParser:
    """The demcal command line: one subcommand per entry of :data:`COMMANDS`."""
    top = Parser(prog="demcal", description="Calibrate DEM simulations.")
    commands = top.add_subparsers(dest="command", required=True)
    for name, text, func, arguments in COMMANDS:
        sub = commands.add_parser(name, help=text)
        sub.set_defaults(func=func)
        if name not in WITHOUT_CONFIG:
            sub.add_argument(
                "config",
                nargs="?",
                default=DEFAULT_CONFIG,
                help="the study's YAML file"
                + ("" if name in ("run", "convergence") else ", or its name once it has run"),
            )
        if arguments is not None:
            arguments(sub)
    return top


def main(argv: list[str] | None = None) -> int:
    """Run one demcal command; a user's mistake or a disk error is one line, never a traceback."""
    args = parser().parse_args(argv)
    command: Command = args.func
    try:
        return command(args)
    except DemcalError as exc:
        print(f"demcal: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # full disk, permissions: finished evaluations stay on disk
        print(
            f"demcal: {exc}; fix it and run the same command again (finished evaluations are kept)",
            file=sys.stderr,
        )
        return 2
    except KeyboardInterrupt:  # Ctrl-C in a command without its own handling, e.g. a model fit
        print("demcal: interrupted; run the same command again", file=sys.stderr)
        return 130
    except Exception as exc:  # a bug: say where the details are, keep the terminal clean
        return internal_error(exc)


def internal_error(exc: Exception) -> int:
    """Report a bug: the traceback goes to the study's log if one is open, else to stderr."""
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
