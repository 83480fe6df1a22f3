"""The progress display: a bar that fits the terminal, plain lines elsewhere and in the log."""

import io

from demcal.daemon.progress import Progress, ProgressDisplay, answer_text, clock
from demcal.optimizer.evaluation import BestPoint, Evaluation
from demcal.results.records import Status

PROGRESS = Progress(
    "unit",
    3,
    20,
    1,
    1,
    2,
    "best 0.01 at sliding_friction_pp=0.35, rolling_friction_pp=0.07",
    75.0,
    425.0,
)


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_the_plain_line_says_counts_best_and_time_to_budget():
    assert PROGRESS.line() == (
        "[demcal unit] 3/20 done, 2 running, 1 failed, 1 stopped early | "
        "0:01:15 elapsed, ~0:07:05 to budget | "
        "best 0.01 at sliding_friction_pp=0.35, rolling_friction_pp=0.07"
    )
    other_rule = Progress(**{**PROGRESS.__dict__, "to_budget_s": None})
    assert "to budget" not in other_rule.line()
    assert clock(3 * 3600 + 61) == "3:01:01" and clock(-5) == "0:00:00"


def test_without_a_terminal_a_plain_line_every_so_often_and_the_last_state_at_close():
    stream, log = io.StringIO(), io.StringIO()
    display = ProgressDisplay(stream, log, every_s=3600)
    display(PROGRESS)
    display(Progress(**{**PROGRESS.__dict__, "finished": 4}))  # within the hour: not written
    assert stream.getvalue().count("\n") == 1 and "3/20" in stream.getvalue()
    display.close()  # the last state is written once more, in the log too
    assert stream.getvalue().splitlines()[-1].startswith("[demcal unit] 4/20 done")
    assert log.getvalue() == stream.getvalue()
    assert "\r" not in stream.getvalue()


def test_on_a_terminal_one_bar_rewritten_in_place_never_wider_than_the_terminal(monkeypatch):
    monkeypatch.setenv("COLUMNS", "70")  # what tqdm reads when the stream has no window size
    monkeypatch.setenv("LINES", "24")
    terminal, log = Terminal(), io.StringIO()
    display = ProgressDisplay(terminal, log, every_s=3600)
    for finished in range(3, 9):
        display(Progress(**{**PROGRESS.__dict__, "finished": finished}))
    display.close()
    shown = [part for part in terminal.getvalue().replace("\n", "\r").split("\r") if part.strip()]
    assert shown and all(len(part) <= 70 for part in shown), shown
    assert "8/20 done" in shown[-1] and terminal.getvalue().endswith("\n")
    assert terminal.getvalue().count("\n") == 1  # one line on screen, rewritten
    assert log.getvalue().count("\n") == 2 and "\r" not in log.getvalue()  # first and last state


def test_the_answer_and_the_lowest_run_are_named_apart():
    """The answer is the point the models predict best; a lucky noisy run may be lower, and
    the line says which is which (issue 36, item 2)."""
    records = [
        Evaluation(11, (0.5, 0.5), False, Status.OK, 2.9e-4),
        Evaluation(13, (0.6, 0.4), False, Status.OK, 3.0e-6),
    ]
    best = BestPoint(11, [0.3, 0.09], 2.9e-4, 2.2e-5, "response models", [])
    names = ["sliding_friction_pp", "rolling_friction_pp"]
    assert answer_text(best, records, names) == (
        "answer e0011 (sliding_friction_pp=0.3, rolling_friction_pp=0.09) predicted 2.2e-05; "
        "lowest run e0013 3e-06"
    )
    alone = answer_text(best, records[:1], names)
    assert alone.endswith("predicted 2.2e-05, also the lowest run")
    assert answer_text(None, [], names) == "no result yet"
