"""Confirmation runs: the best point simulated ``confirm_replicates`` more times after the stop.

A confirmation is an ordinary evaluation record marked ``"confirms": id``
(the id of the point it repeats): it joins the response data, early
termination never stops it, and the point it confirms stays the best point.
"""

from __future__ import annotations

import numpy as np

from demcal.results.records import Status


def confirmed_id(records: list[dict]) -> int | None:
    """The id of the point the confirmation runs repeat; None before any."""
    return next((r["confirms"] for r in records if "confirms" in r), None)


def confirmation_summary(records: list[dict], keys: list[str]) -> dict | None:
    """The confirmation runs so far: which point, their ids, pending and failed counts, and per
    response of ``keys`` the mean, sd and count of their replicate means; None before any."""
    runs = [r for r in records if "confirms" in r]
    if not runs:
        return None
    finished = [r for r in runs if r["status"] == Status.OK and r.get("responses")]
    responses = {}
    for key in keys:
        means = [
            float(np.mean(r["responses"][key]["values"])) for r in finished if key in r["responses"]
        ]
        if means:
            responses[key] = {
                "mean": float(np.mean(means)),
                "sd": float(np.std(means, ddof=1)) if len(means) > 1 else 0.0,
                "count": len(means),
            }
    return {
        "confirms": runs[0]["confirms"],
        "ids": [r["id"] for r in runs],
        "pending": sum(r["status"] == Status.PENDING for r in runs),
        "failed": sum(r["status"] in (Status.FAILED, Status.TERMINATED) for r in runs),
        "responses": responses,
    }
