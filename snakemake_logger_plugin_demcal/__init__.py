"""demcal's Snakemake logger: the terminal shows Snakemake's warnings and errors, nothing else.

The shipped profiles select it (``logger: [demcal]``), so ``snakemake
--profile ...`` prints demcal's progress line and answer without Snakemake's
job listings, while every warning and error still shows. (Snakemake's own
``quiet: all`` would hide the errors too.) A dry run (``-n``) is all listing,
so there it shows everything Snakemake's own logger would.

Snakemake reads the files given with ``--configfile`` before it runs the
Snakefile, and stops on an unreadable one (a directory, text that is not
UTF-8, a YAML alias bomb that expands to gigabytes) with a traceback or in
silence. This logger is set up before that, so it first reads those files with
demcal's strict study reader and stops on a bad one with the same one line
``demcal run`` prints.
"""

from __future__ import annotations

import argparse
import logging
import sys

from snakemake_interface_logger_plugins.base import LogHandlerBase


def configfiles(argv: list[str]) -> list[str]:
    """The files of ``--configfile``/``--configfiles`` on a Snakemake command line."""
    parser = argparse.ArgumentParser(add_help=False, allow_abbrev=False)
    parser.add_argument("--configfile", "--configfiles", nargs="+", action="extend", default=[])
    known, _ = parser.parse_known_args(argv)
    return known.configfile


def check_study_files(argv: list[str]) -> None:
    """Read each study file of the command line as ``demcal run`` would; stop on a bad one."""
    paths = configfiles(argv)
    if not paths:
        return
    from demcal.errors import ConfigError
    from demcal.study.study_file import read_study_yaml

    for path in paths:
        try:
            read_study_yaml(path)
        except ConfigError as exc:
            print(f"demcal: {exc}", file=sys.stderr)
            raise SystemExit(1) from None


class LogHandler(LogHandlerBase):
    """Snakemake's records at WARNING and above (in a dry run, INFO and above through
    Snakemake's filter), formatted by Snakemake, to standard error."""

    def __post_init__(self) -> None:
        check_study_files(sys.argv[1:])
        self.setLevel(logging.INFO if self.common_settings.dryrun else logging.WARNING)

    def emit(self, record: logging.LogRecord) -> None:
        try:
            print(self.format(record), file=sys.stderr, flush=True)
        except Exception:  # noqa: BLE001  (logging's own rule: a handler never raises)
            self.handleError(record)

    @property
    def writes_to_stream(self) -> bool:
        return True

    @property
    def writes_to_file(self) -> bool:
        return False

    @property
    def has_filter(self) -> bool:
        # the level set above; Snakemake's quiet filter would hide the errors, but in a dry
        # run it keeps --quiet working
        return not self.common_settings.dryrun

    @property
    def has_formatter(self) -> bool:
        return False  # Snakemake's own formatting of its messages

    @property
    def needs_rulegraph(self) -> bool:
        return False
