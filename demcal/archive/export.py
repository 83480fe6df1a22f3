"""The archive as tables: one row per simulation with units in the column headers, written as
CSV or Parquet (pandas; Parquet through pyarrow).

Columns: the provenance (``study``, ``evaluation``, ``scene``, ``replicate``, ``attempt``,
``seed``, ``engine``, ``engine_version``, ``settings`` as JSON, ``timestep_fraction [-]``,
``fidelity``, the level it ran at),
``status`` and ``reason``, the cost (``cost.cpu [s]``, ``cost.wall [s]``,
``cost.particle_steps [-]``), then ``psd.<setting> [unit]``, ``parameter.<name> [unit]``
(``free_parameters`` lists the free ones) and ``response.<name> [unit]`` with
``response.<name>.final`` (false: the last estimate of a stopped run, which could still
have changed).
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path

import pandas as pd

from demcal.archive.simulation import ArchivedSimulation
from demcal.errors import ConfigError

#: The file types ``write_table`` knows, by suffix.
FORMATS = (".csv", ".parquet")
#: Columns of text, which CSV leaves empty where the text is (and pandas reads NaN back).
TEXT = (
    "key",
    "study",
    "evaluation",
    "scene",
    "engine",
    "engine_version",
    "settings",
    "fidelity",
    "status",
    "reason",
    "free_parameters",
    "source",
    "demcal_version",
)


#: The columns every export has, in order; then psd.*, parameter.* and response.* ones.
FIXED_COLUMNS = (
    "id",
    "key",
    "study",
    "evaluation",
    "scene",
    "replicate",
    "attempt",
    "seed",
    "engine",
    "engine_version",
    "settings",
    "timestep_fraction [-]",
    "fidelity",
    "status",
    "reason",
    "free_parameters",
    "cost.cpu [s]",
    "cost.wall [s]",
    "cost.particle_steps [-]",
    "started_at [s since 1970]",
    "ended_at [s since 1970]",
    "recorded_at [s since 1970]",
    "source",
    "demcal_version",
)


def frame(records: Iterable[ArchivedSimulation]) -> pd.DataFrame:
    """One row per record; the columns of the module's docstring."""
    rows = []
    for r in records:
        row: dict[str, object] = {
            "id": r.id,
            "key": r.key,
            "study": r.study,
            "evaluation": r.evaluation,
            "scene": r.scene,
            "replicate": r.replicate,
            "attempt": r.attempt,
            "seed": r.seed,
            "engine": r.engine,
            "engine_version": r.engine_version,
            "settings": json.dumps(r.settings, sort_keys=True),
            "timestep_fraction [-]": r.timestep_fraction,
            "fidelity": r.fidelity,
            "status": str(r.status),
            "reason": r.reason,
            "free_parameters": " ".join(sorted(r.free)),
            "cost.cpu [s]": r.cost.get("cpu_s"),
            "cost.wall [s]": r.cost.get("wall_s"),
            "cost.particle_steps [-]": r.cost.get("particle_steps"),
            "started_at [s since 1970]": r.started_at,
            "ended_at [s since 1970]": r.ended_at,
            "recorded_at [s since 1970]": r.recorded_at,
            "source": r.source,
            "demcal_version": r.demcal_version,
        }
        for group, values in (("psd", r.psd), ("parameter", r.parameters)):
            row |= {f"{group}.{name} [{q.unit}]": q.value for name, q in values.items()}
        for name, q in r.responses.items():
            row[f"response.{name} [{q.unit}]"] = q.value
            row[f"response.{name}.final"] = r.final.get(name, False)
        rows.append(row)
    table = pd.DataFrame(rows)
    grouped = sorted(set(table.columns) - set(FIXED_COLUMNS), key=_group_order)
    return _final_flags(table.reindex(columns=[*FIXED_COLUMNS, *grouped]))


def _final_flags(table: pd.DataFrame) -> pd.DataFrame:
    """The ``.final`` columns as true/false/missing (a failed run has no responses)."""
    flags = [c for c in table.columns if c.endswith(".final")]
    return table.astype(dict.fromkeys(flags, "boolean"))


def _group_order(column: str) -> tuple[int, str]:
    group = column.split(".", 1)[0]
    return ("psd", "parameter", "response").index(group), column


def write_table(table: pd.DataFrame, path: Path) -> None:
    """``table`` to ``path``: CSV or Parquet by its suffix."""
    path = Path(path)
    if path.suffix not in FORMATS:
        raise ConfigError(
            f"{path}: give a file ending in {' or '.join(FORMATS)} (the export's format)"
        )
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix == ".csv":
        table.to_csv(path, index=False)
    else:
        table.to_parquet(path, index=False)


def read(path: Path) -> pd.DataFrame:
    """A table ``write_table`` wrote."""
    path = Path(path)
    if path.suffix != ".csv":
        return pd.read_parquet(path)
    table = pd.read_csv(path)
    for column in TEXT:
        table[column] = table[column].fillna("")
    return _final_flags(table)
