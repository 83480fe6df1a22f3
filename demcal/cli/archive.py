"""``demcal archive list|show|export|import|stats``: the simulations every study recorded.

Each command works on one archive: ``--url`` names it, ``--archive-of`` takes that of a study
(its YAML file or its name once it has run); without either, the archive of the study that
``--study`` names when it is known here, else the default archive (``results/archive.sqlite``).
``--study`` keeps the simulations of one study (``list``, ``export``, ``stats``).
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

from demcal.archive.export import frame, write_table
from demcal.archive.importer import ImportReport, import_results, study_folders
from demcal.archive.simulation import ArchivedSimulation
from demcal.archive.store import Archive
from demcal.cli.options import LARGEST_ROW, former_name, whole_number
from demcal.cli.study_argument import has_run, study_of
from demcal.daemon.tables import iso_time
from demcal.errors import ConfigError, DemcalError
from demcal.results.archive_url import check_url, missing_file, shown
from demcal.results.layout import RESULTS
from demcal.results.records import FINE, Status
from demcal.study.schema import default


def arguments(sub: argparse.ArgumentParser) -> None:
    """The actions of ``demcal archive`` and their options."""
    actions = sub.add_subparsers(dest="action", required=True)
    listing = actions.add_parser("list", help="one line per stored simulation")
    show = actions.add_parser("show", help="everything stored of one simulation")
    show.add_argument("simulation", help="its number (from list) or the start of its key")
    export = actions.add_parser("export", help="write the simulations to a CSV or Parquet file")
    export.add_argument("file", type=Path, help="FILE.csv or FILE.parquet")
    importing = actions.add_parser(
        "import", help="archive the simulations already in results/<study>/ folders"
    )
    importing.add_argument(
        "folders",
        nargs="*",
        type=Path,
        help=f"results/<study>/ folders (default: every study in {RESULTS}/)",
    )
    stats = actions.add_parser("stats", help="simulations and cost per study, scene and status")
    for action in (listing, show, export, importing, stats):
        where = action.add_mutually_exclusive_group()
        where.add_argument(
            "--url",
            help="the archive's URL (default: that of the study --study names, else "
            f"{default('archive')['url']})",
        )
        where.add_argument(
            "--archive-of",
            metavar="STUDY",
            help="use this study's archive (its YAML file, or its name once it has run)",
        )
    for action in (listing, export, stats):
        action.add_argument(
            "--study",
            metavar="NAME",
            help="only this study's simulations (a YAML file stands for its study's name)",
        )
    for action in (listing, export):
        former_name(action, "--of", "--study")
        action.add_argument("--scene", help="only simulations of this scene")
        action.add_argument("--engine", help="only simulations on this engine")
        action.add_argument(
            "--status",
            nargs="+",
            choices=[s.value for s in Status if s != Status.PENDING],
            default=[],
            help="only simulations that ended so",
        )
    listing.add_argument(
        "--limit",
        type=whole_number(1, LARGEST_ROW),
        help="at most this many (the oldest first)",
    )


def archive_url(args: argparse.Namespace) -> str:
    """The archive the command works on: ``--url``, the archive of ``--archive-of``, that of
    the study ``--study`` names when it is known here, else the default archive."""
    if args.url is not None:
        return check_url(args.url, "--url")
    named = args.archive_of or known_study(getattr(args, "study", None))
    if named is not None:
        study = study_of(named)
        if study.archive is None:
            raise ConfigError(f"study {study.name!r} keeps no archive (archive: false)")
        return study.archive
    url: str = default("archive")["url"]
    return url


def known_study(argument: str | None) -> str | None:
    """``argument`` if it names a study known here: a YAML file, or one that has run."""
    if argument is None or not (Path(argument).is_file() or has_run(argument)):
        return None
    return argument


def study_name(argument: str | None) -> str | None:
    """The name of the study ``--study`` filters by: a YAML file's study, or the word itself
    (the archive may hold studies run elsewhere)."""
    if argument is None or not Path(argument).is_file():
        return argument
    return study_of(argument).name


def archive(args: argparse.Namespace) -> int:
    url = archive_url(args)
    absent = missing_file(url)
    if absent is not None and args.action != "import":  # reading must not make the file
        raise ConfigError(
            f"no archive at {absent} yet: the first simulation of a study with this archive "
            f"makes it, or 'demcal archive import' of results/<study>/ folders"
        )
    with Archive(url) as store:
        if args.action == "import":
            return import_command(store, args.folders)
        if args.action == "stats":
            return stats_command(store, study_name(args.study))
        if args.action == "show":
            record = store.get(simulation_word(args.simulation))
            if record is None:  # or it is too damaged to read: the summary says why
                raise ConfigError(
                    store.damage_summary()
                    or f"{shown(url)} holds no simulation {args.simulation!r} (give its number or "
                    f"at least 6 characters of its key, as 'demcal archive list' shows them)"
                )
            store.warn_damaged()
            print(describe(record))
            return 0
        records = store.records(
            study=study_name(args.study),
            scene=args.scene,
            engine=args.engine,
            statuses=args.status,
            limit=getattr(args, "limit", None),
        )
        store.warn_damaged()
    if args.action == "export":
        write_table(frame(records), args.file)
        print(f"demcal: {len(records)} simulations from {shown(url)} written to {args.file}")
        return 0
    width = shutil.get_terminal_size().columns if sys.stdout.isatty() else None
    for record in records:
        print(line(record, width))
    if not records:
        print(f"demcal: no simulations in {shown(url)} match")
    return 0


def simulation_word(word: str) -> str:
    """``archive show``'s word, checked: digits are a simulation's number, one the archive can
    hold."""
    if word.isdigit():
        try:
            whole_number(1, LARGEST_ROW)(word)
        except argparse.ArgumentTypeError as exc:
            raise ConfigError(
                f"archive show: {exc} (a simulation's number); or give at least 6 characters "
                f"of its key"
            ) from None
    return word


def line(record: ArchivedSimulation, width: int | None = None) -> str:
    """One simulation in one line: number, origin (with its fidelity level unless fine),
    status, start time (ISO 8601, UTC), free parameters and responses (``~``: an estimate) or
    why it failed. Wider than ``width`` characters, it is two, the parameters on the second,
    each cut to ``width``."""
    level = "" if record.fidelity == FINE else f" [{record.fidelity}]"
    head = (
        f"{record.id:>6} {record.study}/{record.evaluation} {record.scene}{level} "
        f"rep{record.replicate} {record.status} {iso_time(record.started_at)}"
    )
    free = " ".join(
        f"{name}={q.value:.4g}" for name, q in record.parameters.items() if name in record.free
    )
    outcome = " ".join(
        f"{name}={q.value:.4g}{'' if record.final.get(name) else '~'}"
        for name, q in record.responses.items()
    ) or (f"reason: {record.reason}" if record.reason else "")
    text = f"{head} {free} | {outcome}".rstrip(" |")
    if width is None or len(text) <= width:
        return text
    lines = [f"{head} {outcome}".rstrip(), f"{'':7}{free}"]
    return "\n".join(
        text if len(text) <= width else text[: width - 1] + "…" for text in lines if text.strip()
    )


def describe(record: ArchivedSimulation) -> str:
    """Everything stored of one simulation, as indented JSON."""
    return json.dumps(
        {
            "id": record.id,
            "key": record.key,
            **record.provenance,
            "parameters": {n: f"{q.value:g} {q.unit}" for n, q in record.parameters.items()},
            "free": sorted(record.free),
            "psd": {n: f"{q.value:g} {q.unit}" for n, q in record.psd.items()},
            "status": str(record.status),
            "reason": record.reason,
            "responses": {
                n: f"{q.value:g} {q.unit}" + ("" if record.final.get(n) else " (estimate)")
                for n, q in record.responses.items()
            },
            "cost": record.cost,
            "started_at": iso_time(record.started_at),
            "ended_at": iso_time(record.ended_at),
            "recorded_at": iso_time(record.recorded_at),
            "source": record.source,
            "demcal_version": record.demcal_version,
        },
        indent=2,
    )


def import_command(store: Archive, folders: list[Path]) -> int:
    """Import each folder; a folder that cannot be read is reported and the others go on."""
    folders = folders or study_folders(RESULTS)
    if not folders:
        print(f"demcal: no studies in {RESULTS}/ to import (give results/<study>/ folders)")
        return 0
    failed = 0
    for folder in folders:
        try:
            report: ImportReport = import_results(store, folder)
        except DemcalError as exc:
            print(f"{folder}: not imported: {exc}")
            failed += 1
            continue
        print(
            f"{folder}: study {report.study}: {report.found} simulations found, "
            f"{report.added} new in {shown(store.url)}"
        )
        for skipped in report.skipped:
            print(f"  skipped {skipped}")
    return 2 if failed else 0


def stats_command(store: Archive, study: str | None) -> int:
    """Simulations and cost per study, scene, engine and status (of ``study`` only if given)."""
    rows = [row for row in store.stats() if study in (None, row["study"])]
    store.warn_damaged()
    if not rows:
        which = "" if study is None else f" of study {study!r}"
        print(f"demcal: {shown(store.url)} holds no simulations{which} yet")
        return 0
    total = sum(row["simulations"] for row in rows)
    print(f"{shown(store.url)}: {total} simulations")
    for row in rows:
        cpu = row["cpu_s"] or 0.0
        steps = (
            "" if row["particle_steps"] is None else f", {row['particle_steps']:.3g} particle-steps"
        )
        print(
            f"  {row['study']} {row['scene']} {row['engine']} {row['status']}: "
            f"{row['simulations']} ({cpu / 3600:.3g} CPU h{steps})"
        )
    return 0
