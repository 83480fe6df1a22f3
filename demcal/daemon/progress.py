"""The calibration's progress: what it is (``Progress``) and how it is shown.

On a terminal a tqdm bar rewrites itself in place and fits the terminal's
width; elsewhere (a pipe, a batch job's output) a plain line is written every
``PLAIN_EVERY_S`` seconds. A log file, when given, gets the plain lines too.
"""

from __future__ import annotations

import shutil
import sys
import time
from dataclasses import dataclass
from typing import NoReturn, TextIO

from tqdm import tqdm

from demcal.optimizer.best import lowest_run
from demcal.optimizer.evaluation import BestPoint, Evaluation
from demcal.results.layout import evaluation_id

#: Seconds between plain progress lines where nothing can be rewritten in place.
PLAIN_EVERY_S = 30.0


def answer_text(best: BestPoint | None, records: list[Evaluation], names: list[str]) -> str:
    """The progress line's end: the answer (the predicted best evaluated point) and the lowest
    single run, each named by its evaluation; "no result yet" before any."""
    lowest = lowest_run(records)
    if best is None or lowest is None:
        return "no result yet"
    values = ", ".join(f"{n}={v:.3g}" for n, v in zip(names, best.x))
    text = f"answer {_named(best.id, best.reused_from)} ({values}) predicted {best.predicted:.3g}"
    if lowest.id == best.id:
        return f"{text}, also the lowest run"
    return f"{text}; lowest run {_named(lowest.id, lowest.reused_from)} {lowest.value:.3g}"


def _named(proposal: int, reused_from: str | None) -> str:
    return reused_from or evaluation_id(proposal)


def clock(seconds: float) -> str:
    """``h:mm:ss`` of a duration."""
    seconds = int(max(seconds, 0))
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"


@dataclass(frozen=True)
class Progress:
    """Counts of a calibration at one moment; ``to_budget_s`` only when the budget is the stop
    to expect (None when another stopping rule may end the run first)."""

    study: str
    finished: int
    budget: int
    failed: int
    stopped: int
    running: int
    best: str
    elapsed_s: float
    to_budget_s: float | None
    #: the evaluations done at a cheaper level, as "+9 coarse" ("" without one)
    cheaper: str = ""

    def status(self) -> str:
        """Everything but the study and the count of finished evaluations."""
        eta = "" if self.to_budget_s is None else f", ~{clock(self.to_budget_s)} to budget"
        return (
            f"{self.running} running, {self.failed} failed, {self.stopped} stopped early | "
            f"{clock(self.elapsed_s)} elapsed{eta} | {self.best}"
        )

    def line(self) -> str:
        cheaper = f" ({self.cheaper})" if self.cheaper else ""
        return f"[demcal {self.study}] {self.finished}/{self.budget} done{cheaper}, {self.status()}"


class ProgressDisplay:
    """Shows each ``Progress`` it is called with; ``close()`` ends the bar's line."""

    def __init__(
        self, stream: TextIO = sys.stderr, log: TextIO | None = None, every_s: float = PLAIN_EVERY_S
    ):
        self.stream, self.log, self.every_s = stream, log, every_s
        self.interactive = stream.isatty()
        self.bar: tqdm[NoReturn] | None = None
        self.last: Progress | None = None
        self.last_plain = -float("inf")

    def __call__(self, progress: Progress, plain_now: bool = False) -> None:
        self.last = progress
        if self.interactive:
            self._update_bar(progress)
        now = time.monotonic()
        if plain_now or now - self.last_plain >= self.every_s:
            self.last_plain = now
            if not self.interactive:
                print(progress.line(), file=self.stream, flush=True)
            if self.log is not None:
                print(progress.line(), file=self.log, flush=True)

    def _update_bar(self, progress: Progress) -> None:
        # read every time (follows a resize); shutil's fallback covers a terminal of size 0
        width, height = shutil.get_terminal_size()
        if self.bar is None:
            self.bar = tqdm(
                total=progress.budget,
                initial=progress.finished,
                file=self.stream,
                ncols=width - 1,
                nrows=height,
                postfix=progress.status(),
                desc=f"[demcal {progress.study}]",
                leave=True,
                bar_format="{desc} {bar:12} {n_fmt}/{total_fmt} done{postfix}",
            )
        self.bar.ncols = width - 1
        self.bar.total = max(progress.budget, progress.finished)
        self.bar.n = progress.finished
        self.bar.set_postfix_str(progress.status(), refresh=False)
        self.bar.refresh()

    def close(self) -> None:
        """Show the last state as a plain line too (log, pipe) and end the bar's line."""
        if self.last is not None:
            self(self.last, plain_now=True)
        if self.bar is not None:
            self.bar.close()
            self.bar = None
