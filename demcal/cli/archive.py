"""``demcal archive list|show|export|import|stats``: the simulations every study recorded.

Each command works on one archive: ``--url`` names it, ``--study`` takes that of a study (its
YAML file or its name once it has run); the default is the default archive
(``results/archive.sqlite``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from demcal.archive import tables
from demcal.archive.importer import ImportReport, import_results, study_folders
from demcal.archive.record import ArchivedSimulation
from demcal.archive.store import Archive
from demcal.archive.url import check_url, missing_file, shown
from demcal.cli.options import LARGEST_ROW, whole_number
from demcal.errors import ConfigError, DemcalError
from demcal.results.layout import RESULTS
from demcal.results.records import Status
from demcal.study.config import default


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
        where.add_argument("--url", help="the archive's URL (default: the default archive)")
        where.add_argument("--study", help="use this study's archive (its YAML file or name)")
    for action in (listing, export):
        action.add_argument("--of", dest="of_study", metavar="STUDY", help="only this study's")
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
    """The archive the command works on."""
    if args.url is not None:
        return check_url(args.url, "--url")
    if args.study is not None:
        from demcal.cli.inspect import study_of

        study = study_of(args.study)
        if study.archive is None:
            raise ConfigError(f"study {study.name!r} keeps no archive (archive: false)")
        return study.archive
    url: str = default("archive")["url"]
    return url


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
            return stats_command(store)
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
            study=args.of_study,
            scene=args.scene,
            engine=args.engine,
            statuses=args.status,
            limit=getattr(args, "limit", None),
        )
        store.warn_damaged()
    if args.action == "export":
        tables.write(tables.frame(records), args.file)
        print(f"demcal: {len(records)} simulations from {shown(url)} written to {args.file}")
        return 0
    for record in records:
        print(line(record))
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


def line(record: ArchivedSimulation) -> str:
    """One simulation in one line: number, key, origin, status and responses."""
    responses = " ".join(
        f"{name}={q.value:.4g}{'' if record.final.get(name) else '~'}"
        for name, q in record.responses.items()
    )
    return (
        f"{record.id:>6} {record.key[:12]} {record.study}/{record.evaluation} {record.scene} "
        f"rep{record.replicate} seed {record.seed} {record.engine} {record.status} {responses}"
    ).rstrip()


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
            "started_at": record.started_at,
            "ended_at": record.ended_at,
            "recorded_at": record.recorded_at,
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


def stats_command(store: Archive) -> int:
    rows = store.stats()
    store.warn_damaged()
    if not rows:
        print(f"demcal: {shown(store.url)} holds no simulations yet")
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
