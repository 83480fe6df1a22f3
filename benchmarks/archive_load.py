"""The archive under load (issue 21): concurrent writers, a writer killed with SIGKILL inside its
transaction, and ``demcal archive import`` of the results folders on this machine.

    python benchmarks/archive_load.py [--writers 8] [--records 500] [--postgres URL]
        [--import FOLDER ...] [--out benchmarks/results/archive_load.json]

Each writer is a process that writes its records one transaction per record, then its first
tenth again (retried jobs): once opening and closing the archive around each record, as the
extract jobs do (the migration check included), once over one open archive. The archive is
an SQLite file in a temporary folder and, with ``--postgres`` (or DEMCAL_TEST_POSTGRES_URL;
``.ci/postgres/start.sh`` starts a throwaway server), a PostgreSQL database whose archive
tables are dropped first.
Checks: every record stored once, with all its parameter and response rows; after SIGKILL, no
row of the killed transaction. The import counts the simulations of every study folder (a
folder with a study.json) found in the ``--import`` folders, down to two levels.
"""

from __future__ import annotations

import argparse
import glob
import json
import multiprocessing
import os
import random
import signal
import statistics
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

from sqlalchemy import func, select

from demcal.archive.importer import import_results
from demcal.archive.schema import ParameterRow, ResponseRow, SimulationRow
from demcal.archive.simulation import PSD_SETTINGS, ArchivedSimulation, Quantity
from demcal.archive.store import Archive, drop
from demcal.physics.catalogue import CATALOG
from demcal.results.archive_url import open_engine
from demcal.results.records import Status
from demcal.study.config import load_study_file

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "config" / "examples" / "analytic.yaml"
#: Folders that may hold studies here: this checkout's results, the other checkouts' and
#: the benchmarks' result folders (/work/after_results, /work/quick_run1, ...).
IMPORT_CANDIDATES = ("results", "/work/*", "/work/*/results")


def template() -> ArchivedSimulation:
    """A record of the analytic example's cylinder lift: its settings and all 8 parameters."""
    study = load_study_file(EXAMPLE, check_engine=False)
    settings = study.settings["cylinder_lift"]
    parameters = study.parameters_for(study.centre_point())
    return ArchivedSimulation(
        study="load",
        evaluation="",
        scene="cylinder_lift",
        replicate=0,
        engine="analytic",
        engine_version="analytic-1",
        settings=settings,
        timestep_fraction=study.timestep_fraction,
        status=Status.OK,
        attempt=0,
        parameters={n: Quantity(v, CATALOG[n].unit) for n, v in parameters.items()},
        free=frozenset(p.name for p in study.free),
        psd={
            n: Quantity(float(settings[n]), study.scenes["cylinder_lift"].settings[n].unit)
            for n in PSD_SETTINGS
        },
        responses={
            "angle_of_repose": Quantity(25.0, "deg"),
            "bulk_density": Quantity(1450.0, "kg/m^3"),
        },
        final={"angle_of_repose": True, "bulk_density": True},
        cost={"cpu_s": 60.0, "wall_s": 61.0, "particle_steps": 2.0e8},
    )


def records(base: ArchivedSimulation, writer: int, count: int) -> list[ArchivedSimulation]:
    """The records of one writer: an evaluation each, its own seed and point."""
    rng = random.Random(writer)
    return [
        replace(
            base,
            evaluation=f"w{writer}-e{i:04d}",
            seed=writer * 100_000 + i,
            parameters={
                **base.parameters,
                "sliding_friction_pp": Quantity(rng.uniform(0.1, 0.9), "-"),
            },
        )
        for i in range(count)
    ]


def write(url: str, writer: int, count: int, study: str, reopen: bool) -> dict:
    """One writer, a transaction per record; ``reopen``: as the jobs write (open the archive,
    add one record, close it), else over one open archive. Then a tenth again (retries)."""
    mine = records(replace(template(), study=study), writer, count)
    seconds, added = [], 0
    archive = None if reopen else Archive(url)
    for record in mine + mine[: count // 10]:
        start = time.perf_counter()
        if archive is None:
            with Archive(url) as opened:
                added += opened.add([record])
        else:
            added += archive.add([record])
        seconds.append(time.perf_counter() - start)
    if archive is not None:
        archive.close()
    return {"added": added, "seconds": seconds}


def rows(url: str, study: str | None = None) -> tuple[int, int, int, int]:
    """Simulations, parameter rows, response rows and distinct keys (of one study, if given)."""
    chosen = select(SimulationRow.id)
    if study is not None:
        chosen = chosen.where(SimulationRow.study == study)
    engine = open_engine(url)
    with engine.connect() as connection:
        counts = [
            connection.execute(
                select(func.count()).select_from(table).where(column.in_(chosen))
            ).scalar_one()
            for table, column in (
                (SimulationRow, SimulationRow.id),
                (ParameterRow, ParameterRow.simulation_id),
                (ResponseRow, ResponseRow.simulation_id),
            )
        ]
        keys = connection.execute(
            select(func.count(SimulationRow.key.distinct())).where(SimulationRow.id.in_(chosen))
        ).scalar_one()
    engine.dispose()
    return counts[0], counts[1], counts[2], keys


def concurrent(url: str, writers: int, count: int, reopen: bool) -> dict:
    Archive(url).close()  # the schema first, as the first job of a study makes it
    study = "load-reopen" if reopen else "load-kept"
    start = time.perf_counter()
    with multiprocessing.get_context("fork").Pool(writers) as pool:
        results = pool.starmap(write, [(url, w, count, study, reopen) for w in range(writers)])
    wall = time.perf_counter() - start
    seconds = sorted(s for r in results for s in r["seconds"])
    simulations, parameters, responses, keys = rows(url, study)
    expected = writers * count
    return {
        "writers": writers,
        "records per writer": count,
        "writes (with retries)": len(seconds),
        "added": sum(r["added"] for r in results),
        "stored": simulations,
        "distinct keys": keys,
        "complete": parameters == 8 * simulations and responses == 2 * simulations,
        "none lost or duplicated": simulations == keys == expected
        and sum(r["added"] for r in results) == expected,
        "ms per write: median": 1e3 * statistics.median(seconds),
        "ms per write: p95": 1e3 * seconds[int(0.95 * len(seconds))],
        "ms per write: max": 1e3 * seconds[-1],
        "records per s (all writers)": len(seconds) / wall,
        "wall s": wall,
    }


def slow(base: ArchivedSimulation, ready: str) -> Iterator[ArchivedSimulation]:
    """Records of one transaction that stops after the third, inside it."""
    for i in range(3):
        yield replace(base, evaluation=f"killed-{i}", seed=900_000 + i)
    Path(ready).touch()
    time.sleep(600)
    yield replace(base, evaluation="killed-3", seed=900_003)


def killed(url: str, folder: Path, trials: int) -> dict:
    """SIGKILL a writer inside its transaction ``trials`` times while another writer writes."""
    base = template()
    before = rows(url)
    survived = []
    for trial in range(trials):
        ready = folder / f"ready{trial}"
        pid = os.fork()
        if pid == 0:
            try:
                Archive(url).add(slow(replace(base, study=f"killed{trial}"), str(ready)))
            finally:
                os._exit(1)
        while not ready.exists():
            time.sleep(0.005)
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        with Archive(url) as archive:  # the next writer is not blocked by the dead one
            survived.append(len(archive.records(study=f"killed{trial}")))
            archive.add(records(replace(base, study=f"after{trial}"), 99, 1))
    after = rows(url)
    return {
        "trials": trials,
        "rows of killed transactions": sum(survived),
        "writes after each kill": after[0] - before[0],
        "complete": after[1] == 8 * after[0] and after[2] == 2 * after[0],
    }


def study_folders(candidates: list[str]) -> list[Path]:
    """The study folders (with a study.json) in or one level below the candidate folders."""
    found: set[Path] = set()
    for base in (Path(p) for pattern in candidates for p in glob.glob(pattern)):
        for depth in ("*/study.json", "*/*/study.json"):
            found |= {path.parent.resolve() for path in base.glob(depth)}
    return sorted(found)


def imported(folder: Path, candidates: list[str]) -> dict:
    url = f"sqlite:///{folder / 'import.sqlite'}"
    report: dict = {"folders": {}}
    with Archive(url) as archive:
        start = time.perf_counter()
        for study in study_folders(candidates):
            try:
                first = import_results(archive, study)
            except Exception as exc:  # noqa: BLE001  (a folder demcal cannot read is reported)
                report["folders"][str(study)] = f"not imported: {exc}"
                continue
            second = import_results(archive, study)
            report["folders"][str(study)] = {
                "found": first.found,
                "added": first.added,
                "added by a second import": second.added,
                "skipped": len(first.skipped),
            }
        report["seconds"] = time.perf_counter() - start
        report["records"] = archive.count()
    return report


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--writers", type=int, default=8)
    parser.add_argument("--records", type=int, default=500)
    parser.add_argument("--kills", type=int, default=5)
    parser.add_argument("--postgres", default=os.environ.get("DEMCAL_TEST_POSTGRES_URL"))
    parser.add_argument("--import", dest="folders", nargs="*", default=list(IMPORT_CANDIDATES))
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks/results/archive_load.json")
    args = parser.parse_args()
    out: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        urls = {"sqlite": f"sqlite:///{folder / 'archive.sqlite'}"}
        if args.postgres:
            drop(args.postgres)
            urls["postgresql"] = args.postgres
        for name, url in urls.items():
            out[name] = {
                "concurrent, each write opens the archive (as the jobs)": concurrent(
                    url, args.writers, args.records, reopen=True
                ),
                "concurrent, one open archive per writer": concurrent(
                    url, args.writers, args.records, reopen=False
                ),
                "kill -9": killed(url, folder, args.kills),
            }
            print(name, json.dumps(out[name], indent=2), flush=True)
        out["import"] = imported(folder, args.folders)
        print("import", json.dumps(out["import"], indent=2))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(out, indent=2) + "\n")
    ok = all(
        all(run["none lost or duplicated"] and run["complete"] for run in list(db.values())[:2])
        and db["kill -9"]["rows of killed transactions"] == 0
        and db["kill -9"]["complete"]
        for name, db in out.items()
        if name != "import"
    )
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
