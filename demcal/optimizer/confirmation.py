"""Confirmation runs: the best point simulated ``confirm_replicates`` more times after the stop.

A confirmation is an ordinary evaluation record whose ``confirms`` is the id
of the point it repeats: it joins the response data, early
termination never stops it, and the point it confirms stays the best point.
"""

from __future__ import annotations

import numpy as np

from demcal.results.records import Status

from .evaluation import Confirmation, ConfirmedResponse, Evaluation


def confirmed_id(records: list[Evaluation]) -> int | None:
    """The id of the point the confirmation runs repeat; None before any."""
    return next((r.confirms for r in records if r.confirms is not None), None)


def confirmation_summary(records: list[Evaluation], keys: list[str]) -> Confirmation | None:
    """The confirmation runs so far: which point, their ids, pending and failed counts, and per
    response of ``keys`` the mean, sd and count of their replicate means; None before any."""
    confirms = confirmed_id(records)
    if confirms is None:
        return None
    runs = [r for r in records if r.confirms is not None]
    finished = [r for r in runs if r.finished]
    responses = {}
    for key in keys:
        means = [r.responses[key].mean for r in finished if key in r.responses]
        if means:
            responses[key] = ConfirmedResponse(
                mean=float(np.mean(means)),
                sd=float(np.std(means, ddof=1)) if len(means) > 1 else 0.0,
                count=len(means),
            )
    return Confirmation(
        confirms=confirms,
        ids=[r.id for r in runs],
        pending=sum(r.status == Status.PENDING for r in runs),
        failed=sum(r.status in (Status.FAILED, Status.TERMINATED) for r in runs),
        responses=responses,
    )
