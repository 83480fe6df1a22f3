"""evaluations.csv and best.json, written from evaluations run in-process and a told optimizer."""

from __future__ import annotations

import csv
import json
import math
import os
from dataclasses import replace
from datetime import UTC, datetime

import pytest
from helpers import analytic_example, evaluate, new_optimizer, read_objective

from demcal.daemon.tables import evaluation_columns, write_best, write_evaluations_csv
from demcal.results.layout import evaluation_id
from demcal.results.records import PointRecord, Status
from demcal.results.storage import write_json
from demcal.study.config import load_study
from demcal.study.model import freeze

#: The analytic engine fails every run with sliding friction in this interval.
FAILING = {"when": {"sliding_friction_pp": [0.14, 0.16]}, "reason": "injected for the test"}


@pytest.fixture
def study(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    config = analytic_example(
        optimizer={"response_model": "cubic_rbf", "confirm_replicates": 2},
        engine={"failures": [FAILING]},
    )
    return freeze(load_study(config))


def rows(study) -> list[dict]:
    with open(study.files.evaluations_csv, newline="") as handle:
        return list(csv.DictReader(handle))


def test_evaluations_csv_has_a_row_per_evaluation_with_what_its_records_say(study):
    optimizer = new_optimizer(study)
    done = [evaluate(study, optimizer, proposal) for proposal in optimizer.ask(3)]
    failed = evaluate(study, optimizer, optimizer.add_point([0.15, 0.1]))
    (pending,) = optimizer.ask(1)  # handed out, not finished: no objective.json yet
    PointRecord(dict(zip(["sliding_friction_pp", "rolling_friction_pp"], pending.x))).write(
        study.files.evaluation(evaluation_id(pending.id)).params
    )
    launched = study.files.evaluation("e0001")
    started = os.stat(launched.objective).st_mtime - 42.0
    write_json(launched.launch, {"pid": 1, "started_at": started})
    write_evaluations_csv(study)

    table = rows(study)
    assert list(table[0]) == [column for column, _, _ in evaluation_columns(study)]
    assert [row["evaluation"] for row in table] == ["e0000", "e0001", "e0002", "e0003", "e0004"]
    assert [row["status"] for row in table] == [
        Status.OK,
        Status.OK,
        Status.OK,
        Status.FAILED,
        Status.PENDING,
    ]
    for row, record in zip(table, done):
        assert float(row["objective"]) == pytest.approx(record["objective"], rel=1e-6)
        assert row["attempts"] == "1"
        for name, value in record["parameters"].items():
            assert float(row[name]) == pytest.approx(value, rel=1e-6)
        for key, values in record["replicates"].items():
            assert float(row[key]) == pytest.approx(sum(values) / len(values), rel=1e-6)
            assert [float(row[f"{key}.rep{r}"]) for r in range(2)] == pytest.approx(values, 1e-6)
        assert float(row["cpu_s"]) == pytest.approx(record["cost"]["cpu_s"], rel=1e-6)
        assert row["ended_at"].endswith("Z")
    assert table[3]["reason"] == failed["reason"]
    assert "injected for the test" in table[3]["reason"]
    assert table[3]["objective"] == table[4]["objective"] == ""
    assert table[4]["ended_at"] == table[4]["wall_s"] == ""
    # launch time and wall time where launch.json says when the evaluation started
    assert table[1]["started_at"] == datetime.fromtimestamp(started, UTC).strftime(
        "%Y-%m-%dT%H:%M:%SZ"
    )
    assert float(table[1]["wall_s"]) == pytest.approx(42.0, abs=1e-3)
    assert table[0]["started_at"] == table[0]["wall_s"] == ""


def test_the_columns_sidecar_gives_units_and_meanings(study):
    write_evaluations_csv(study)
    with open(study.files.evaluations_columns, newline="") as handle:
        sidecar = {row["column"]: row["unit"] for row in csv.DictReader(handle)}
    assert list(sidecar) == [column for column, _, _ in evaluation_columns(study)]
    assert sidecar["sliding_friction_pp"] == "-"
    assert sidecar["cylinder_lift.angle_of_repose"] == "deg"
    assert sidecar["cylinder_lift.bulk_density.rep1"] == "kg/m^3"
    assert sidecar["wall_s"] == "s"
    assert rows(study) == []  # no evaluation yet: the header only


def test_best_json_is_the_optimizers_best_point_with_its_records(study):
    optimizer = new_optimizer(study)
    for proposal in optimizer.ask(4):
        evaluate(study, optimizer, proposal)
    best = optimizer.best()
    write_best(study, best, optimizer.confirmation(), "evaluation budget spent")

    written = json.loads(study.files.best.read_text())
    record = read_objective(study.files.evaluation(evaluation_id(best.id)))
    assert written["evaluation"] == evaluation_id(best.id)
    assert written["stop_reason"] == "evaluation budget spent"
    assert written["parameters"] == record["parameters"]
    assert written["parameters"] == dict(
        zip(["sliding_friction_pp", "rolling_friction_pp"], best.x)
    )
    assert written["objective"] == best.value == pytest.approx(record["objective"], rel=1e-12)
    assert written["predicted_objective"] == best.predicted
    assert written["chosen_by"] == best.chosen_by
    assert written["responses"] == record["responses"]
    assert written["targets"] == {
        "cylinder_lift.angle_of_repose": 25.0,
        "cylinder_lift.bulk_density": 1450.0,
    }
    assert written["relative_errors"] == record["relative_errors"]
    assert written["units"] == {
        "sliding_friction_pp": "-",
        "rolling_friction_pp": "-",
        "cylinder_lift.angle_of_repose": "deg",
        "cylinder_lift.bulk_density": "kg/m^3",
    }
    assert written["target_spreads"] == {
        "cylinder_lift.angle_of_repose": None,
        "cylinder_lift.bulk_density": None,
    }
    assert "confirmation" not in written


def test_best_json_names_the_parameters_on_a_bound(study):
    optimizer = new_optimizer(study)
    (proposal,) = optimizer.ask(1)
    evaluate(study, optimizer, proposal)
    best = replace(optimizer.best(), on_bounds=[(1, "upper"), (0, "lower")])
    write_best(study, best)
    written = json.loads(study.files.best.read_text())
    assert written["on_bounds"] == {"rolling_friction_pp": "upper", "sliding_friction_pp": "lower"}
    assert written["stop_reason"] is None


def test_best_json_carries_the_confirmation_runs(study):
    optimizer = new_optimizer(study)
    for proposal in optimizer.ask(3):
        evaluate(study, optimizer, proposal)
    confirming = optimizer.confirm()
    assert len(confirming) == 2
    evaluate(study, optimizer, confirming[0])
    best = optimizer.best()
    write_best(study, best, optimizer.confirmation(), None)
    halfway = json.loads(study.files.best.read_text())["confirmation"]
    assert halfway["of"] == evaluation_id(best.id)
    assert halfway["evaluations"] == ["e0003", "e0004"]
    assert halfway["pending"] == 1
    assert halfway["failed"] == 0
    first = read_objective(study.files.evaluation("e0003"))["responses"]
    assert halfway["responses"]["cylinder_lift.angle_of_repose"] == {
        "mean": pytest.approx(first["cylinder_lift.angle_of_repose"], rel=1e-12),
        "sd": 0.0,
        "count": 1,
    }

    evaluate(study, optimizer, confirming[1])
    write_best(study, optimizer.best(), optimizer.confirmation(), "evaluation budget spent")
    done = json.loads(study.files.best.read_text())
    assert done["evaluation"] == halfway["of"]  # the confirmed point stays the answer
    assert done["confirmation"]["pending"] == 0
    second = read_objective(study.files.evaluation("e0004"))["responses"]
    means = [first["cylinder_lift.bulk_density"], second["cylinder_lift.bulk_density"]]
    entry = done["confirmation"]["responses"]["cylinder_lift.bulk_density"]
    assert entry["count"] == 2
    assert entry["mean"] == pytest.approx(sum(means) / 2, rel=1e-12)
    assert entry["sd"] == pytest.approx(abs(means[0] - means[1]) / math.sqrt(2), rel=1e-9)
