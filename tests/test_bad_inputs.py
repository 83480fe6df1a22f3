"""The bad-input corpus through every route a user has: one line naming the field or file.

Each study file of tests/bad_inputs.py goes through ``demcal run`` and the
README's ``snakemake --profile profiles/local|slurm --configfile=FILE``; each
must print one line, the same on every route, with no traceback, no
simulation started and nothing written outside ``results/``. The alias bomb
is also measured: refused in well under a second, in little memory.
"""

import re
import subprocess
import sys
import time
import tracemalloc
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from bad_commands import gathered_cases, run_command
from bad_inputs import CASES, POINTS, ROUTES, BadInput, route_command, run_route, write_point

from demcal.errors import ConfigError
from demcal.study.study_file import read_study_yaml


def test_the_corpus_is_large_and_its_messages_distinct():
    assert len(CASES) + len(POINTS) >= 60
    assert len({c.name for c in CASES}) == len(CASES)


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
@pytest.mark.slow
def test_every_route_refuses_a_bad_study_in_one_line(tmp_path, case):
    with ThreadPoolExecutor(len(ROUTES)) as pool:
        outcomes = dict(
            zip(
                ROUTES,
                pool.map(
                    lambda route: run_route(route, case, tmp_path / route.replace(" ", "_")), ROUTES
                ),
            )
        )
    verdicts = {route: outcome.verdict(case.message) for route, outcome in outcomes.items()}
    assert set(verdicts.values()) == {"clean"}, {r: (verdicts[r], o) for r, o in outcomes.items()}
    lines = {
        o.lines[0].replace(str(tmp_path / r.replace(" ", "_")), "") for r, o in outcomes.items()
    }
    assert len(lines) == 1, lines  # the same line on every route


@pytest.mark.parametrize("point", POINTS, ids=lambda p: p.name)
@pytest.mark.slow
def test_a_bad_hand_written_point_is_a_failed_evaluation_with_its_reason(tmp_path, point):
    """The README's "evaluate your own point": recorded as failed, summarised, exit 0."""
    study, target = write_point(tmp_path, point)
    done = subprocess.run(
        route_command("snakemake local", study, target=target),
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    output = done.stdout + done.stderr
    assert done.returncode == 0 and "Traceback" not in output, output
    assert f"evaluation '{point.name}' of study 'corpus': failed" in output, output
    reason = next(line for line in output.splitlines() if line.startswith("  reason: "))
    assert re.search(point.reason, reason), reason


@pytest.mark.slow
def test_an_alias_bomb_is_refused_in_well_under_a_second_and_little_memory(tmp_path):
    bomb = next(c for c in CASES if c.name == "alias_bomb_mapping")
    path = bomb.write(tmp_path)
    tracemalloc.start()
    start = time.perf_counter()
    with pytest.raises(ConfigError, match="aliases expand to more than"):
        read_study_yaml(path)
    seconds = time.perf_counter() - start
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert seconds < 0.5 and peak < 20e6, (seconds, peak)
    # whole processes, both routes: each under a small parent that reports its child's peak
    # resident size (RUSAGE_CHILDREN of this test's own process would include earlier tests):
    # under 200 MB in all (a start-up that imports more than it needs fails here too), and
    # little more than the same route refusing a small bad YAML file
    peak_of_child = (
        "import resource, subprocess, sys; subprocess.run(sys.argv[1:], "
        "capture_output=True, timeout=60); "
        "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)"
    )
    small = next(c for c in CASES if c.name == "recursive_alias").write(tmp_path)

    def peak_kb(route: str, study: Path) -> int:
        done = subprocess.run(
            [sys.executable, "-c", peak_of_child, *route_command(route, study)],
            cwd=tmp_path,
            capture_output=True,
            text=True,
            timeout=90,
        )
        return int(done.stdout)

    for route in ("demcal run", "snakemake local"):
        resident = peak_kb(route, path)
        assert resident < 200 * 1024, (route, f"{resident / 1024:.0f} MB")
        extra = resident - peak_kb(route, small)
        assert extra < 20 * 1024, (route, f"{extra / 1024:.0f} MB more than a small bad file")


def test_the_bomb_would_expand_to_billions(tmp_path):
    """The bomb is real: its expanded size, counted, is 9**10 values."""
    from demcal.study.study_file import StrictLoader, expanded_size

    bomb: BadInput = next(c for c in CASES if c.name == "alias_bomb")
    loader = StrictLoader(bomb.raw.decode())
    assert expanded_size(loader.get_single_node(), 10**12) > 3 * 10**9
    assert sys.getsizeof(bomb.raw) < 1000


def test_an_internal_error_says_where_its_traceback_is(tmp_path, monkeypatch, capsys):
    """A bug before the study's log exists: the traceback is printed, not promised in daemon.log."""
    import demcal.cli
    import demcal.daemon.session

    def broken(*_):
        raise RuntimeError("a bug")

    monkeypatch.setattr(demcal.daemon.session, "load_study_file", broken)
    assert demcal.cli.main(["run", str(tmp_path / "any.yaml")]) == 3
    err = capsys.readouterr().err
    where = re.search(r"internal error: RuntimeError: a bug \(traceback (above|in (\S+));", err)
    assert where, err
    text = err if where.group(1) == "above" else open(where.group(2)).read()
    assert "Traceback (most recent call last)" in text and "a bug" in text


@pytest.mark.parametrize("case", gathered_cases(), ids=lambda c: c.name)
@pytest.mark.slow
def test_every_other_command_refuses_bad_input_in_one_line_or_warns_and_goes_on(tmp_path, case):
    outcome = run_command(case, tmp_path)
    assert outcome.verdict(case) == "clean", outcome.lines[-20:]
