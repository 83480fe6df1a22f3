"""The command line as one convention (issue 36): a study by its YAML file or its name, one word
per concept with the former names still read, the study after NAME=VALUE words, ``--version``,
``demcal check`` and ``demcal report``."""

from __future__ import annotations

import copy
import re

import pytest
import yaml
from helpers import ANALYTIC_STUDY, demcal, finish

from demcal.archive.simulation import ArchivedSimulation, Quantity
from demcal.cli import main, parser
from demcal.cli.archive import line
from demcal.cli.inspect import answer_words
from demcal.results.records import BestRecord, Status
from demcal.study.config import load_study
from demcal.study.model import freeze


def parse(*words: str):
    return parser(words).parse_args(list(words))


def refusal(capsys, *words: str) -> str:
    """The one line a refused command prints (exit code 2)."""
    with pytest.raises(SystemExit) as ended:
        parse(*words)
    assert ended.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("demcal: "), err
    return err


def test_version_names_demcal_snakemake_and_lammps(capsys):
    with pytest.raises(SystemExit) as ended:
        parse("--version")
    assert ended.value.code == 0
    out = capsys.readouterr().out
    assert re.fullmatch(r"demcal \S+ \(Snakemake \S+, LAMMPS [^)]+\)\n", out), out


def test_the_study_may_follow_the_parameter_values():
    args = parse("solutions", "--point", "a=1", "b=2", "quickstart")
    assert (args.config, args.point) == ("quickstart", ["a=1", "b=2"])
    args = parse("solutions", "quickstart", "--point", "a=1", "b=2")
    assert (args.config, args.point) == ("quickstart", ["a=1", "b=2"])
    args = parse("add-point", "a=1", "b=2")  # no study: the default, both words are values
    assert (args.config, args.values) == ("config/config.yaml", ["a=1", "b=2"])
    args = parse("add-point", "a=1", "b=2", "beads")
    assert (args.config, args.values) == ("beads", ["a=1", "b=2"])
    args = parse("convergence", "--point", "a=1", "beads")
    assert (args.config, args.point) == ("beads", ["a=1"])
    assert parse("convergence").point == []  # the option's default list is left as it was


def test_a_study_given_twice_or_no_values_is_one_line(capsys):
    err = refusal(capsys, "solutions", "one", "--point", "a=1", "two")
    assert "solutions: the study is given twice, 'one' and 'two'" in err
    err = refusal(capsys, "solutions", "--point", "quickstart")
    assert "solutions: --point: give NAME=VALUE for every free parameter" in err


def test_the_former_option_names_still_work_and_stay_out_of_the_help():
    assert parse("solutions", "--k", "3").tolerance == 3.0
    assert parse("solutions").tolerance == 2.0
    assert parse("sample", "s.yaml", "--n", "4").points == 4
    assert parse("convergence", "--jobs", "3").workers == 3
    assert parse("archive", "list", "--of", "beads").study == "beads"

    def help_of(command: str) -> str:
        return parser([command])._subparsers._group_actions[0].choices[command].format_help()  # type: ignore[union-attr]

    for command, old in (("solutions", "--k"), ("sample", "--n"), ("convergence", "--jobs")):
        assert not re.search(rf"{old}\b", help_of(command))
    assert "--points N" in help_of("sample")
    assert "--tolerance K" in help_of("solutions")


def test_sample_without_points_is_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["sample", "s.yaml"]) == 2
    assert capsys.readouterr().err == (
        "demcal: sample: give --points N, the number of points of the design\n"
    )


def write(tmp_path, name: str = "beads") -> str:
    config = {**copy.deepcopy(ANALYTIC_STUDY), "study": name, "replicates": 1}
    (tmp_path / f"{name}.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    return f"{name}.yaml"


def test_check_says_what_run_would_run_and_writes_nothing(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["check", write(tmp_path), "--workers", "3"]) == 0
    out = capsys.readouterr().out
    assert "demcal check: beads.yaml is a valid study, 'beads'" in out
    assert "  free parameters: sliding_friction_pp 0.1 … 0.9, rolling_friction_pp 0.02 … 0.3" in out
    assert "cylinder_lift.angle_of_repose 25 deg, cylinder_lift.bulk_density 1450 kg/m^3" in out
    assert "  budget: at most 100 evaluations" in out
    assert "  workers: 3 evaluations in flight (--workers)" in out
    assert "how long they take is not known yet" in out and "results/beads/ (new)" in out
    assert not (tmp_path / "results").exists()


def test_check_says_what_a_cheaper_level_may_spend(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    config = {
        **copy.deepcopy(ANALYTIC_STUDY),
        "study": "levels",
        "replicates": 1,
        "fidelities": {"coarse": {"engine": {"scale": 0.9}}},
        "optimizer": {"max_evaluations": 10, "fidelity": "coarse"},
    }
    (tmp_path / "levels.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    assert main(["check", "levels.yaml"]) == 0
    out = capsys.readouterr().out
    assert "  fidelity levels: coarse besides fine; the search may spend coarse (at most 3" in out
    assert "; and at most 30 at coarse" in out


def test_check_refuses_a_bad_study_and_a_name_in_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    config = {**copy.deepcopy(ANALYTIC_STUDY), "replicates": 0}
    (tmp_path / "bad.yaml").write_text(yaml.safe_dump(config))
    assert main(["check", "bad.yaml"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "replicates" in err, err
    freeze(load_study(copy.deepcopy(ANALYTIC_STUDY)))  # results/unit/study.json
    assert main(["check", "unit"]) == 2
    assert capsys.readouterr().err.startswith(
        "demcal: check needs the study's YAML file: 'unit' is the name of a study that has run"
    )


def test_report_refuses_a_study_that_has_not_finished(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    freeze(load_study(copy.deepcopy(ANALYTIC_STUDY)))
    assert main(["report", "unit"]) == 2
    assert capsys.readouterr().err == (
        "demcal: study 'unit' has not run yet: 'demcal run STUDY.yaml' calibrates it, then "
        "'demcal report unit' makes its report\n"
    )
    assert main(["report", "nonesuch"]) == 2
    assert "'nonesuch': no such study file, and no study of that name" in capsys.readouterr().err


@pytest.mark.slow
def test_run_says_how_to_get_the_report_and_report_makes_it(tmp_path):
    config = write(tmp_path)
    text = (tmp_path / config).read_text() + "optimizer: {max_evaluations: 4}\n"
    (tmp_path / config).write_text(text)
    out = finish(demcal(tmp_path, "run", config, "--workers", "2"))
    assert out.endswith("report: demcal report beads makes results/beads/report.html\n"), out
    out = finish(demcal(tmp_path, "report", "beads"))
    assert "demcal: report: results/beads/report.html" in out
    assert (tmp_path / "results/beads/plots/solution_space.png").stat().st_size > 0
    assert (tmp_path / "results/beads/report.html").stat().st_size > 0
    listing = finish(demcal(tmp_path, "studies"))
    assert re.search(r"; answer e\d{4} \(predicted [\d.e-]+\)", listing), listing


def test_studies_names_the_answer_and_a_lowest_run_elsewhere():
    best = BestRecord("e0012", {}, 0.5, predicted_objective=0.41)
    assert answer_words(best) == "; answer e0012 (predicted 0.41)"
    best = BestRecord(
        "e0012",
        {},
        0.5,
        predicted_objective=0.41,
        lowest_run={"evaluation": "e0003", "objective": 0.2},
    )
    assert answer_words(best) == "; answer e0012 (predicted 0.41), lowest run e0003 (objective 0.2)"


def test_an_archive_line_shows_free_values_and_an_iso_time_within_the_width():
    record = ArchivedSimulation(
        study="beads",
        evaluation="e0001",
        scene="cylinder_lift",
        replicate=0,
        engine="lammps",
        engine_version="lammps 1",
        settings={},
        timestep_fraction=0.25,
        status=Status.OK,
        parameters={
            "sliding_friction_pp": Quantity(0.3, "-"),
            "restitution_pp": Quantity(0.5, "-"),
        },
        free=frozenset({"sliding_friction_pp"}),
        responses={"angle_of_repose": Quantity(17.84, "deg")},
        final={"angle_of_repose": True},
        started_at=0.0,
        id=7,
    )
    full = line(record)
    assert full == (
        "     7 beads/e0001 cylinder_lift rep0 ok 1970-01-01T00:00:00Z sliding_friction_pp=0.3 "
        "| angle_of_repose=17.84"
    )
    narrow = line(record, 70).splitlines()
    assert len(narrow) == 2 and all(len(text) <= 70 for text in narrow)
    assert narrow[1].strip() == "sliding_friction_pp=0.3"


def test_output_piped_into_a_reader_that_stops_early_ends_quietly(tmp_path):
    """`demcal check STUDY | head -1`: the reader closes the pipe; no 'Broken pipe' advice."""
    import os
    import subprocess
    import sys

    from helpers import ANALYTIC_EXAMPLE

    read_end, write_end = os.pipe()
    os.close(read_end)  # the reader has already gone, as head has once it has its line
    try:
        run = subprocess.run(
            [sys.executable, "-m", "demcal.cli", "check", str(ANALYTIC_EXAMPLE)],
            stdout=write_end,
            stderr=subprocess.PIPE,
            cwd=tmp_path,
            timeout=120,
            check=False,
        )
    finally:
        os.close(write_end)
    errors = run.stderr.decode()
    assert run.returncode == 141, errors
    assert "Broken pipe" not in errors and "Traceback" not in errors
