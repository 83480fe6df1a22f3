"""The Python API (demcal.open, demcal.load): results read back, errors named, a study run."""

from __future__ import annotations

import json
import logging
import re
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
import yaml
from helpers import ANALYTIC_STUDY, calibrate, config
from matplotlib.figure import Figure

import demcal
from demcal.errors import ConfigError, DemcalError
from demcal.results.records import BestRecord


@pytest.fixture
def calibrated(tmp_path, monkeypatch):
    """A finished calibration of 8 evaluations in tmp_path/results/unit (in-process)."""
    monkeypatch.chdir(tmp_path)
    study = config()
    study["optimizer"]["response_model"] = "cubic_rbf"  # the fast model: no Kriging fits
    _, _, reason = calibrate(study)
    return tmp_path / "results" / "unit", reason


def test_open_reads_every_result_of_a_calibration(calibrated):
    folder, reason = calibrated
    results = demcal.open("results/unit")
    assert results.files.dir == folder and demcal.open("unit").files.dir == folder
    assert results.study.name == "unit" and [p.name for p in results.study.free] == [
        "sliding_friction_pp",
        "rolling_friction_pp",
    ]
    table = results.evaluations
    assert list(table["evaluation"]) == [f"e{i:04d}" for i in range(8)]
    assert set(table["status"]) == {"ok"} and table["objective"].notna().all()
    units = table.attrs["units"]
    assert list(units) == list(table.columns)
    assert units["rolling_friction_pp"] == "-" and units["cylinder_lift.angle_of_repose"] == "deg"
    assert units["cylinder_lift.bulk_density.rep1"] == "kg/m^3" and units["wall_s"] == "s"
    # times in UTC; the in-process launcher writes no launch.json, so no start time
    assert str(table["started_at"].dt.tz) == str(table["ended_at"].dt.tz) == "UTC"
    assert table["ended_at"].notna().all() and table["started_at"].isna().all()
    answer = results.answer
    assert answer.record == BestRecord.read(folder / "best.json") == results.best.record
    row = table.set_index("evaluation").loc[answer.evaluation]
    assert row["objective"] == pytest.approx(answer.objective, rel=1e-6)  # 7 digits
    assert results.finished.reason == reason == "evaluation budget reached (8 of 8)"
    optimizer = results.optimizer
    assert optimizer.completed_evaluations() == 8 and optimizer.ask() == []  # budget spent
    assert "unit" in repr(results) and reason in repr(results)
    assert f"answer {answer.evaluation}, objective" in repr(results)


def test_the_answer_shows_itself_in_a_few_lines_and_as_a_table(calibrated):
    folder, _ = calibrated
    results = demcal.open(folder)
    answer = results.answer
    shown = repr(answer)
    assert len(shown.splitlines()) <= 5 and len(shown) < 500
    assert shown.startswith(f"<demcal answer of 'unit': evaluation {answer.evaluation} (")
    assert re.search(
        r"sliding_friction_pp = [\d.]+ \[-\], rolling_friction_pp = [\d.]+ \[-\]", shown
    )
    assert re.search(r"objective [\d.e-]+ predicted, [\d.e-]+ observed in its own runs", shown)
    table = answer.to_frame()
    assert list(table.index) == [
        "sliding_friction_pp",
        "rolling_friction_pp",
        "cylinder_lift.angle_of_repose",
        "cylinder_lift.bulk_density",
        "objective",
    ]
    assert table.loc["cylinder_lift.bulk_density", "unit"] == "kg/m^3"
    assert table.loc["cylinder_lift.bulk_density", "target"] == 1450.0
    assert table.loc["objective", "value"] == answer.objective
    assert results.lowest_run is None  # the answer is also the lowest single run here
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        _ = answer.nothing


def test_the_lowest_single_run_is_named_apart_from_the_answer(calibrated):
    folder, _ = calibrated
    best = json.loads((folder / "best.json").read_text())
    best["lowest_run"] = {"evaluation": "e0003", "objective": 0.001}
    (folder / "best.json").write_text(json.dumps(best))
    results = demcal.open(folder)
    lowest = results.lowest_run
    assert (lowest.evaluation, lowest.objective) == ("e0003", 0.001)
    assert repr(lowest).startswith(
        f"<demcal lowest single run of 'unit': evaluation e0003, objective 0.001 observed; "
        f"not the answer ({best['evaluation']}): the answer is the point whose objective"
    )
    assert "not the lowest single run (e0003, see .lowest_run)" in repr(results.answer)


def test_confirmation_and_mapping_runs_are_labelled_in_the_evaluations(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    study = config()
    study["optimizer"].update(response_model="cubic_rbf", confirm_replicates=2, map_solutions=2)
    calibrate(study)
    table = demcal.open("unit").evaluations
    assert table["origin"].tolist() == ["new"] * 8 + ["confirmation"] * 2 + ["mapping"] * 2


def test_figures_and_solutions_land_in_the_folder_wherever_it_is(calibrated, tmp_path, monkeypatch):
    """Opened from another working directory: the figures go to the study's plots/, and the
    solution space is read from its optimizer.json, not from ./results/."""
    folder, _ = calibrated
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    results = demcal.open(folder)
    assert results.figures == {}
    figures = results.draw_figures()
    assert "objective_vs_evaluation" in figures and figures == results.figures
    assert all(path.parent == folder / "plots" and path.is_file() for path in figures.values())
    assert not (elsewhere / "results").exists()
    solutions = results.solutions(samples=256)
    assert [verdict.name for verdict in solutions.verdicts] == solutions.analysis.names
    assert solutions.points().shape[1] == 2
    with pytest.raises(ConfigError, match=r"samples is 8; give a whole number from 64 to"):
        results.solutions(samples=8)


#: The figures of the report, each drawn by a method of the results.
REPORT_FIGURES = {
    "plot_optimization_history": "objective_vs_evaluation",
    "plot_objective_vs_time": "objective_vs_time",
    "plot_parameter_traces": "parameter_traces",
    "plot_responses": "responses_vs_targets",
    "plot_parallel_coordinate": "parallel_coordinates",
    "plot_early_termination": "early_termination",
    "plot_answer_history": "answer_history",
}


def png_size(image: bytes) -> tuple[int, int]:
    """The width and height of a PNG image (its IHDR chunk)."""
    assert image[:8] == b"\x89PNG\r\n\x1a\n"
    return int.from_bytes(image[16:20], "big"), int.from_bytes(image[20:24], "big")


def test_every_figure_is_drawn_as_a_figure_the_notebook_shows(calibrated):
    folder, _ = calibrated
    results = demcal.open(folder)
    written = results.draw_figures()
    for method, name in REPORT_FIGURES.items():
        figure = getattr(results, method)()
        assert isinstance(figure, Figure) and figure.axes, method
        width, height = png_size(figure._repr_png_())  # what a notebook shows
        assert width == round(figure.get_figwidth() * 110), method
        if name in written:  # the same drawing as the report's file
            assert png_size(written[name].read_bytes()) == (width, height)
    assert not (folder / "plots" / "answer_history.png").exists()  # drawing writes nothing


def test_the_solution_space_has_named_tables_a_posterior_and_figures(calibrated):
    folder, _ = calibrated
    solutions = demcal.open(folder).solutions(samples=1024)
    shown = repr(solutions)
    assert shown.startswith("<demcal solution space of 'unit': ")
    assert re.search(
        r"of 1024 sampled parameter sets, \d+ are likely to meet every target within 2 sd and "
        r"\d+ cannot be ruled out; posterior of \d+ effective samples",
        shown,
    )
    assert re.search(r"\n  sliding_friction_pp \[-\]: [a-z ]+", shown)
    assert len(shown.splitlines()) == 1 + 2  # a line per free parameter
    columns = ["sliding_friction_pp [-]", "rolling_friction_pp [-]"]
    points = solutions.points()
    assert list(points.columns) == columns
    np.testing.assert_allclose(points.to_numpy(), solutions.analysis.points())
    table = solutions.to_frame()
    assert list(table.columns) == [
        *columns,
        "membership_probability",
        "cylinder_lift.angle_of_repose predicted [deg]",
        "cylinder_lift.angle_of_repose sd [deg]",
        "cylinder_lift.bulk_density predicted [kg/m^3]",
        "cylinder_lift.bulk_density sd [kg/m^3]",
    ]
    sensitivity = solutions.sensitivity
    assert list(sensitivity.index) == ["sliding_friction_pp", "rolling_friction_pp"]
    assert list(sensitivity.columns) == [
        "cylinder_lift.angle_of_repose",
        "cylinder_lift.bulk_density",
    ]
    totals = {(r["parameter"], r["response"]): r["ST"] for r in solutions.analysis.sensitivity}
    assert sensitivity.stack().to_dict() == totals
    posterior = solutions.posterior
    assert list(posterior.columns) == [*columns, "weight"] and len(posterior) == 1024
    assert posterior["weight"].sum() == pytest.approx(1.0)
    assert solutions.effective_samples == pytest.approx(1.0 / (posterior["weight"] ** 2).sum())
    # the posterior's 90 % interval of each parameter, as the verdicts give it, from the sample
    heaviest = posterior.sort_values(columns[0])
    cumulative = heaviest["weight"].cumsum()
    assert heaviest[columns[0]][cumulative >= 0.05].iloc[0] == pytest.approx(
        solutions.verdicts[0].posterior_low
    )
    for method in ("plot_solutions", "plot_sensitivity", "plot_contour"):
        figure = getattr(solutions, method)()
        assert isinstance(figure, Figure) and figure.axes, method
        png_size(figure._repr_png_())


def test_units_come_from_the_study_when_the_sidecar_is_missing(calibrated):
    folder, _ = calibrated
    units = demcal.open(folder).evaluations.attrs["units"]
    (folder / "evaluations.columns.csv").unlink()
    assert demcal.open(folder).evaluations.attrs["units"] == units


def test_a_study_not_run_yet_has_no_best_and_says_what_is_missing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    from demcal.study.config import load_study
    from demcal.study.model import freeze

    freeze(load_study(dict(ANALYTIC_STUDY)))
    results = demcal.open("unit")
    assert results.best is None and results.finished is None and results.figures == {}
    assert results.answer is None and results.lowest_run is None
    assert "(not finished; no answer yet)" in repr(results)
    with pytest.raises(DemcalError, match=r"evaluations.csv is missing: study 'unit' has no"):
        _ = results.evaluations
    with pytest.raises(DemcalError, match=r"evaluations.csv is missing: study 'unit' has no"):
        results.plot_optimization_history()
    with pytest.raises(DemcalError, match=r"optimizer.json is missing"):
        _ = results.optimizer


def test_open_names_the_path_and_what_is_missing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(DemcalError, match=r"no results folder results/nothing: "):
        demcal.open("results/nothing")
    with pytest.raises(DemcalError, match=r"no results folder nothing nor results/nothing"):
        demcal.open("nothing")
    (tmp_path / "plain").mkdir()
    with pytest.raises(DemcalError, match=rf"{tmp_path}/plain is not .* study.json is missing"):
        demcal.open("plain")
    (tmp_path / "study.yaml").write_text("study: x\n")
    with pytest.raises(DemcalError, match=r"study.yaml is a file, not a results folder"):
        demcal.open("study.yaml")


@pytest.fixture
def frozen(tmp_path, monkeypatch):
    """results/unit/ of a study frozen but not run, under tmp_path (the working directory)."""
    monkeypatch.chdir(tmp_path)
    from demcal.study.config import load_study
    from demcal.study.model import freeze

    return freeze(load_study(dict(ANALYTIC_STUDY))).files.dir.resolve()


def damaged(folder, name):
    """``folder`` with binary bytes in its file ``name``."""
    (folder / name).write_bytes(bytes(range(128, 256)) * 4)
    return folder


OPEN_TAKES = r"give a results folder \(a str or Path such as 'results/quickstart'\) or a study's"
LOAD_TAKES = r"give the study's YAML file \(a str or Path\)"


#: Odd arguments of the API: each ends as a DemcalError naming the argument and what it takes.
ODD_ARGUMENTS = [
    (
        "open_a_long_name",
        lambda f: demcal.open("x" * 10_000),
        r"where is 'x+\.\.\.x+': File name too long; " + OPEN_TAKES,
    ),
    (
        "open_none",
        lambda f: demcal.open(None),
        r"demcal.open: where is None \(NoneType\); " + OPEN_TAKES,
    ),
    (
        "open_a_number",
        lambda f: demcal.open(42),
        r"demcal.open: where is 42 \(int\); " + OPEN_TAKES,
    ),
    (
        "open_a_list",
        lambda f: demcal.open([f]),
        r"demcal.open: where is \[.*\] \(list\); " + OPEN_TAKES,
    ),
    (
        "open_an_empty_path",
        lambda f: demcal.open(""),
        r"demcal.open: where is '', not a path; " + OPEN_TAKES,
    ),
    (
        "open_a_nul",
        lambda f: demcal.open("un\0it"),
        r"demcal.open: where is 'un\\x00it', not a path",
    ),
    (
        "open_a_folder_without_a_study",
        lambda f: demcal.open(f.parent),
        r"results is not the results folder of a demcal study: study.json is missing",
    ),
    (
        "open_a_binary_table",
        lambda f: demcal.open(damaged(f, "evaluations.csv")).evaluations,
        r"evaluations.csv: not the table demcal writes \(UnicodeDecodeError: .*\); the file is "
        r"damaged",
    ),
    (
        "open_a_binary_units_table",
        lambda f: (
            demcal.open(
                damaged(damaged(f, "evaluations.csv"), "evaluations.columns.csv")
            ).evaluations
        ),
        r"evaluations.(columns.)?csv: not the table demcal writes",
    ),
    (
        "load_none",
        lambda f: demcal.load(None),
        r"demcal.load: path is None \(NoneType\); " + LOAD_TAKES,
    ),
    (
        "load_a_dict",
        lambda f: demcal.load({"study": "unit"}),
        r"demcal.load: path is \{'study': 'unit'\} \(dict\); " + LOAD_TAKES,
    ),
    ("load_a_number", lambda f: demcal.load(42), r"demcal.load: path is 42 \(int\); " + LOAD_TAKES),
    (
        "load_an_empty_path",
        lambda f: demcal.load(""),
        r"demcal.load: path is '', not a path; " + LOAD_TAKES,
    ),
    (
        "load_a_nul",
        lambda f: demcal.load("study\0.yaml"),
        r"demcal.load: path is 'study\\x00.yaml', not a path",
    ),
    (
        "load_a_folder",
        lambda f: demcal.load(f),
        r"results/unit is a directory; give the study's YAML file",
    ),
    (
        "solutions_k_as_text",
        lambda f: demcal.open(f).solutions(k="2"),
        r"solutions: k is '2'; give a number of standard deviations above 0",
    ),
    (
        "solutions_k_infinite",
        lambda f: demcal.open(f).solutions(k=float("inf")),
        r"solutions: k is inf; give a number",
    ),
    (
        "solutions_samples_as_text",
        lambda f: demcal.open(f).solutions(samples="100"),
        r"solutions: samples is '100'; give a whole number from 64 to 1048576",
    ),
    (
        "solutions_samples_huge",
        lambda f: demcal.open(f).solutions(samples=10**10),
        r"solutions: samples is 10000000000; give a whole number from 64 to 1048576",
    ),
    (
        "solutions_samples_a_float",
        lambda f: demcal.open(f).solutions(samples=100.0),
        r"solutions: samples is 100.0; give a whole number",
    ),
    (
        "solutions_seed_negative",
        lambda f: demcal.open(f).solutions(seed=-1),
        r"solutions: seed is -1; give a whole number of 0 or more",
    ),
]


@pytest.mark.parametrize(
    "call, message", [c[1:] for c in ODD_ARGUMENTS], ids=[c[0] for c in ODD_ARGUMENTS]
)
def test_an_odd_argument_is_a_demcal_error_naming_it(frozen, call, message):
    with pytest.raises(DemcalError, match=message):
        call(frozen)


def test_a_path_may_be_bytes_or_any_path_like(frozen):
    assert demcal.open(bytes(frozen)).files.dir == frozen
    assert demcal.open(frozen).study.name == "unit"


@pytest.mark.parametrize(
    "options, message",
    [
        ({"workers": "two"}, r"run: workers is 'two'; give a whole number of 1 or more"),
        ({"workers": 0}, r"run: workers is 0; give a whole number of 1 or more"),
        ({"profile": 42}, r"run: profile is 42 \(int\); give a Snakemake profile's folder"),
    ],
)
def test_run_names_an_odd_option_before_it_starts(tmp_path, monkeypatch, options, message):
    monkeypatch.chdir(tmp_path)
    study = demcal.load(write_study(tmp_path / "tiny.yaml"))
    with pytest.raises(ConfigError, match=message):
        study.run(**options)
    assert not (tmp_path / "results").exists()


def write_study(path, **changes):
    study = {
        **ANALYTIC_STUDY,
        "study": "tiny",
        "engine": {"name": "analytic", "noise": 0.0, "duration": 0.0},
        "replicates": 1,
        "optimizer": {"max_evaluations": 2, "response_model": "cubic_rbf"},
        "calibration": {"poll_seconds": 0.2},
        **changes,
    }
    path.write_text(yaml.safe_dump(study))
    return path


def test_load_gives_the_study_facts(tmp_path):
    study = demcal.load(write_study(tmp_path / "tiny.yaml"))
    assert study.name == "tiny" and study.warnings == []
    assert study.parameters.to_dict("index") == {
        "sliding_friction_pp": {"lower": 0.1, "upper": 0.9, "unit": "-"},
        "rolling_friction_pp": {"lower": 0.02, "upper": 0.3, "unit": "-"},
    }
    targets = study.targets
    assert list(targets.index) == ["cylinder_lift.angle_of_repose", "cylinder_lift.bulk_density"]
    assert list(targets["unit"]) == ["deg", "kg/m^3"] and list(targets["value"]) == [25.0, 1450.0]
    assert "2 free parameters, 2 targets" in repr(study)


def test_load_names_the_bad_field_as_the_command_line_does(tmp_path):
    bad = write_study(tmp_path / "bad.yaml", engine={"name": "analytic", "duration": -2})
    with pytest.raises(ConfigError, match=r"engine.duration: -2 must be >= 0"):
        demcal.load(bad)
    with pytest.raises(ConfigError, match=r"configuration file not found: .*missing.yaml"):
        demcal.load(tmp_path / "missing.yaml")


def test_import_demcal_stays_light():
    code = (
        "import sys, demcal; heavy = {'pandas', 'scipy', 'demcal.api'} & set(sys.modules); "
        "print(sorted(heavy)); print(demcal.open.__module__)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert out.split("\n")[:2] == ["[]", "demcal.api"]


@pytest.mark.slow
def test_load_run_calibrates_as_demcal_run_and_opens_the_results(tmp_path, monkeypatch):
    """Two evaluations through child Snakemakes (each tens of seconds on a loaded machine)."""
    monkeypatch.chdir(tmp_path)
    study = demcal.load(write_study(tmp_path / "tiny.yaml"))
    results = study.run(workers=2)
    assert results.files.dir == tmp_path / "results" / "tiny"
    assert results.finished.reason == "evaluation budget reached (2 of 2)"
    table = results.evaluations
    assert list(table["status"]) == ["ok", "ok"]
    assert (table["ended_at"] > table["started_at"]).all()  # both known, as datetimes
    assert results.best is not None and results.best.evaluation in ("e0000", "e0001")
    assert json.loads((results.files.dir / "study.json").read_text())["study"] == "tiny"
    assert "INFO launched e0001" in (results.files.dir / "daemon.log").read_text()
    assert logging.getLogger("demcal").handlers == []  # the daemon.log handler is gone
    # the lock is released: a second run in the same process resumes (nothing left to do)
    again = study.run()
    assert again.finished.reason == "evaluation budget reached (2 of 2)"
    pd.testing.assert_frame_equal(again.evaluations, results.evaluations)
