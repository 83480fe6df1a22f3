"""``demcal archive import``: the simulations already in a study's results folder, archived.

Every scene replicate with both its ``simulation.json`` and its ``responses.json`` becomes
one record (:func:`demcal.archive.simulation.from_results`, as its job would have written it),
so importing a folder whose simulations were archived by their jobs, or importing it twice,
adds nothing. A replicate still running (no responses yet), with damaged files, or with a
value that is not a finite number (a NaN response: the archive could not use it) is skipped
and named; the others are imported.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from demcal.archive.simulation import ArchivedSimulation, replicate_record
from demcal.archive.store import Archive, number_flaw
from demcal.errors import ConfigError, SimulationFailed
from demcal.results.layout import SIMULATION_FILE, STUDY_FILE, ReplicateFiles, StudyFiles
from demcal.study.model import load_frozen

#: Records stored per transaction by an import.
BATCH = 500


@dataclass
class ImportReport:
    """What an import found in one results folder and how much of it was new."""

    folder: Path
    study: str = ""
    found: int = 0
    added: int = 0
    skipped: list[str] = field(default_factory=list)


def study_folders(results: Path) -> list[Path]:
    """The study folders under a results folder (those with a study.json)."""
    return sorted(path.parent for path in Path(results).glob(f"*/{STUDY_FILE}"))


def import_results(archive: Archive, folder: Path) -> ImportReport:
    """Archive the simulations of one ``results/<study>/`` folder."""
    files = StudyFiles(Path(folder))
    if not files.study.is_file():
        raise ConfigError(f"{folder}: no study.json here; give a results/<study>/ folder")
    study = load_frozen(files.study)
    report = ImportReport(Path(folder), study.name)
    records: list[ArchivedSimulation] = []
    for path in sorted(files.evals.glob(f"*/*/rep*/{SIMULATION_FILE}")):
        try:
            record = replicate_record(study, ReplicateFiles(path.parent), "import")
        except SimulationFailed as exc:
            report.skipped.append(str(exc))
            continue
        flaws = value_flaws(record)
        if flaws:
            report.skipped.append(f"{path.parent}: {' and '.join(flaws)}")
        else:
            records.append(record)
    report.found = len(records)
    for start in range(0, len(records), BATCH):
        report.added += archive.add(records[start : start + BATCH])
    return report


def value_flaws(record: ArchivedSimulation) -> list[str]:
    """The parameters, psd and responses of ``record`` that are not finite numbers."""
    return [
        flaw
        for kind, values in (
            ("parameter", record.parameters),
            ("psd", record.psd),
            ("response", record.responses),
        )
        for name, quantity in values.items()
        if (flaw := number_flaw(f"{kind} {name}", quantity.value))
    ]
