"""The optimizer's own records: one evaluation, the best point, the confirmation runs.

An `Evaluation` is what the optimizer knows of one point it handed
out: where (unit box), its status, its objective value (the replicates'
mean, the variance of that mean, the replicates) and its responses. It is
frozen: the optimizer replaces a record when it is told, re-scored or
reopened. `BestPoint` is the answer `demcal.optimizer.best` picks and
`Confirmation` what the re-simulations of it found
(`demcal.optimizer.confirmation`). The state file (`demcal.optimizer.state`)
stores evaluations with `Evaluation.to_dict`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from demcal.results.records import FINE, Status


@dataclass(frozen=True)
class ObservedResponse:
    """One response of one evaluation: each replicate's value, and whether it is final.

    ``final`` is False for an early estimate of a run stopped before the
    response was complete (e.g. a mass flow over part of the discharge).
    """

    values: tuple[float, ...]
    final: bool = True

    @property
    def mean(self) -> float:
        """The mean over the replicates."""
        return float(np.mean(self.values))

    @classmethod
    def of(cls, entry: Any) -> ObservedResponse:
        """From ``{"values": [...], "final": bool}`` or a plain list of final values."""
        if isinstance(entry, dict):
            return cls(tuple(float(v) for v in entry["values"]), bool(entry["final"]))
        return cls(tuple(float(v) for v in entry))


@dataclass(frozen=True)
class Evaluation:
    """What the optimizer knows of one evaluation (see the module docstring).

    ``x`` is in the unit box. ``value``, ``variance`` and ``replicates`` are
    set only when the status is ok. ``responses`` are keyed
    ``scene.response``: the replicates' values of an ok run, or what a
    stopped run completed or estimated. ``confirms`` names the point a
    confirmation run repeats; ``by_hand`` marks a point given by hand;
    ``maps_solutions`` one of the solution-set mapping (``map_solutions``);
    ``reused_from`` a point another study simulated, taken from the archive
    (its ``study/evaluation``): data, not a simulation of this study. ``fidelity`` names
    the level it ran at (a cheaper one teaches the fine response models only) and ``cpu_s``
    what its simulations cost (None where not told). ``material``, for a point of a
    neighbouring material taken from the archive (``reuse: neighbours``), is how far each of
    its fixed parameters that differ lies from the study's value (SI units, theirs minus the
    study's): such a point teaches the response models only, with these as inputs.
    """

    id: int
    x: tuple[float, ...]
    in_initial_design: bool
    status: Status = Status.PENDING
    value: float | None = None
    variance: float | None = None
    replicates: tuple[float, ...] | None = None
    responses: dict[str, ObservedResponse] = field(default_factory=dict)
    confirms: int | None = None
    by_hand: bool = False
    maps_solutions: bool = False
    reused_from: str | None = None
    fidelity: str = FINE
    cpu_s: float | None = None
    material: dict[str, float] = field(default_factory=dict)

    @property
    def finished(self) -> bool:
        """Told with status ok: its value enters the surrogate data."""
        return self.status == Status.OK

    def to_dict(self) -> dict[str, Any]:
        """The JSON form in the optimizer's state (the optional marks only when set)."""
        record: dict[str, Any] = {
            "id": self.id,
            "x": list(self.x),
            "status": str(self.status),
            "value": self.value,
            "variance": self.variance,
            "replicates": None if self.replicates is None else list(self.replicates),
            "in_initial_design": self.in_initial_design,
        }
        if self.responses:
            record["responses"] = {
                key: {"values": list(entry.values), "final": entry.final}
                for key, entry in self.responses.items()
            }
        if self.confirms is not None:
            record["confirms"] = self.confirms
        if self.by_hand:
            record["by_hand"] = True
        if self.maps_solutions:
            record["maps_solutions"] = True
        if self.reused_from is not None:
            record["reused_from"] = self.reused_from
        if self.fidelity != FINE:
            record["fidelity"] = self.fidelity
        if self.cpu_s is not None:
            record["cpu_s"] = self.cpu_s
        if self.material:
            record["material"] = self.material
        return record

    @classmethod
    def from_dict(cls, record: dict[str, Any]) -> Evaluation:
        """Inverse of `to_dict`."""
        replicates = record.get("replicates")
        return cls(
            id=int(record["id"]),
            x=tuple(float(v) for v in record["x"]),
            in_initial_design=bool(record["in_initial_design"]),
            status=Status(record["status"]),
            value=record.get("value"),
            variance=record.get("variance"),
            replicates=None if replicates is None else tuple(float(v) for v in replicates),
            responses={
                key: ObservedResponse.of(entry)
                for key, entry in (record.get("responses") or {}).items()
            },
            confirms=record.get("confirms"),
            by_hand=bool(record.get("by_hand", False)),
            maps_solutions=bool(record.get("maps_solutions", False)),
            reused_from=record.get("reused_from"),
            fidelity=record.get("fidelity", FINE),
            cpu_s=record.get("cpu_s"),
            material={k: float(v) for k, v in (record.get("material") or {}).items()},
        )


@dataclass(frozen=True)
class ReusedPoint:
    """A point simulated before by another study, given to the optimizer as data.

    ``x`` in real units; ``responses`` each targeted response's final values, keyed
    ``scene.response``; ``value`` the objective of this study applied to them (None for a
    partial point, where only some targeted responses ran: data of their models only, like a
    run stopped early), and ``replicates`` per replicate (None when the counts differ);
    ``source`` the
    ``study/evaluation`` that simulated it; ``fidelity`` the study's level it ran at;
    ``material`` a neighbouring material's offsets (:attr:`Evaluation.material`).
    """

    x: list[float]
    responses: dict[str, list[float]]
    value: float | None
    replicates: list[float] | None
    source: str
    fidelity: str = FINE
    material: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class BestPoint:
    """The answer of a calibration so far (`demcal.optimizer.best.best_point`).

    ``x`` in real units; ``value`` the observed objective (mean of the
    replicates); ``predicted`` the objective predicted there; ``chosen_by``
    "response models" or "objective surrogate"; ``on_bounds`` the index and
    side ("lower"/"upper") of each coordinate on a bound; ``responses``,
    with response models, each response's predicted (mean, sd); ``reused_from``
    the archive source of a reused point (``study/evaluation``).
    """

    id: int
    x: list[float]
    value: float
    predicted: float
    chosen_by: str
    on_bounds: list[tuple[int, str]]
    responses: dict[str, tuple[float, float]] = field(default_factory=dict)
    reused_from: str | None = None


@dataclass(frozen=True)
class ConfirmedResponse:
    """One response over the confirmation runs: mean, sd and count of their replicate means."""

    mean: float
    sd: float
    count: int


@dataclass(frozen=True)
class Confirmation:
    """The confirmation runs so far (`demcal.optimizer.confirmation.confirmation_summary`).

    ``confirms``: the id of the point they repeat; ``ids``: their ids;
    ``pending`` and ``failed``: how many are still running or gave no result.
    """

    confirms: int
    ids: list[int]
    pending: int
    failed: int
    responses: dict[str, ConfirmedResponse]
