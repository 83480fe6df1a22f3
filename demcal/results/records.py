"""The records that the results files hold (see :mod:`demcal.results.layout` for where they live).

For now the status words. A ``Status`` is a ``str``: it compares equal to the
word read back from a file (``Status.OK == "ok"``), and JSON, CSV and
f-strings write it as that word.
"""

from __future__ import annotations

import enum


class Status(enum.StrEnum):
    """The status of a simulation or an evaluation, as the results files spell it.

    - ``OK``: ran to the end; its responses (and, for an evaluation, its
      objective) are there.
    - ``FAILED``: ended without a usable result, with the reason. The daemon
      retries a failed evaluation up to the study's retries (unless the
      calibration is being stopped); the optimizer never proposes the point,
      nor a small ball around it, again.
    - ``TERMINATED``: stopped early on request (its STOP file, written by
      early termination or ``demcal stop``). The optimizer keeps the point in
      its distance set only; what the run completed or estimated enters the
      response models.
    - ``PENDING``: the optimizer's word for an evaluation handed out and not
      yet told.
    - ``RUNNING``: the evaluations table's word (``StudyFiles.evaluations_csv``)
      for an evaluation whose objective record is not there (or not readable)
      yet: the same evaluations the optimizer calls pending.
    """

    OK = "ok"
    FAILED = "failed"
    TERMINATED = "terminated"
    PENDING = "pending"
    RUNNING = "running"
