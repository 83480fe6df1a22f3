"""The terminal summary of the best point: simulated, predicted ± sd, target ±
spread, bound warnings."""

from helpers import study

from demcal.reporting.terminal import evaluation_summary
from demcal.results.records import BestRecord, ObjectiveRecord
from demcal.study.config import load_study_file


def test_best_point_summary_shows_prediction_spread_and_a_parameter_on_its_bound(tmp_path):
    config = study(
        tmp_path,
        "summary",
        targets=[
            {
                "scene": "cylinder_lift",
                "response": "angle_of_repose",
                "value": 30.0,
                "spread": 1.5,
                "unit": "deg",
            }
        ],
    )
    loaded = load_study_file(config, check_engine=False)
    record = ObjectiveRecord.from_dict(
        {
            "evaluation": "e0007",
            "status": "ok",
            "objective": 0.0012,
            "parameters": {"sliding_friction_pp": 0.9, "rolling_friction_pp": 0.11},
            "responses": {"cylinder_lift.angle_of_repose": 29.0},
            "relative_errors": {"cylinder_lift.angle_of_repose": -1 / 30},
        }
    )
    best = BestRecord(
        "e0007",
        record.parameters,
        0.0012,
        predicted_responses={"cylinder_lift.angle_of_repose": {"mean": 29.4, "sd": 0.31}},
        on_bounds={"sliding_friction_pp": "upper"},
    )
    text = evaluation_summary(loaded, record, tmp_path, best)
    assert "warning: sliding_friction_pp lies on its upper bound (0.9)" in text
    row = next(line for line in text.splitlines() if "angle_of_repose" in line)
    assert row.split()[2:] == ["29", "29.4", "±0.31", "30", "±1.5", "-3.3%"]
    assert "predicted" not in evaluation_summary(loaded, record, tmp_path)


def test_advice_on_a_bound_follows_what_the_targets_identify(tmp_path):
    """Issue 36, item 7: no "widen the bounds" for a parameter the targets do not identify."""
    from demcal.reporting.terminal import bound_advice

    where = tmp_path / "solutions.json"
    assert "widen them" in bound_advice("pinned", where)
    assert "unless `demcal solutions`" in bound_advice(None, where)
    advice = bound_advice("not identified", where)
    assert "widen" not in advice and "do not identify it" in advice and str(where) in advice
