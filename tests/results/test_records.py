"""The typed records: what a malformed file says, and the profile settings demcal needs."""

from __future__ import annotations

import pytest

from demcal.errors import DemcalError, SimulationFailed
from demcal.results.records import LaunchRecord, ObjectiveRecord, PointRecord
from demcal.snakemake_command import check_profile


@pytest.mark.parametrize(
    ("record", "data", "message"),
    [
        (LaunchRecord, {"pid": "123", "started_at": 1.0}, "pid is '123', not an integer"),
        (LaunchRecord, {"pid": 1, "started_at": 1.0, "format": True}, "not a version number"),
        (LaunchRecord, {"pid": 1, "started_at": 1.0, "format": 2}, "written by a newer demcal"),
        (ObjectiveRecord, {"evaluation": "e", "status": "ok"}, "status ok without an objective"),
        (
            ObjectiveRecord,
            {"evaluation": "e", "status": "ok", "objective": 0.1, "cost": None},
            "cost is None, not an object",
        ),
        (ObjectiveRecord, {"evaluation": "e", "status": "done"}, "status 'done' is not one of"),
        (PointRecord, {"parameters": {}, "previous_failures": "abc"}, "not a list of text"),
    ],
)
def test_a_malformed_record_is_refused_naming_the_file_and_field(record, data, message):
    with pytest.raises(
        SimulationFailed, match="^evals/e0001/x.json: .*" + message.replace("(", r"\(")
    ):
        record.from_dict(data, "evals/e0001/x.json")


def test_a_record_of_an_older_demcal_loads():
    """objective.json as 9e9d5c0 wrote it: no format, the targets copied in."""
    old = {
        "evaluation": "e0003",
        "parameters": {"sliding_friction_pp": 0.3},
        "cost": {"cpu_s": 1.0, "simulation_wall_s": 1.2},
        "status": "ok",
        "reason": "",
        "objective": 0.25,
        "timestep_cost": 0.0,
        "responses": {"cylinder_lift.angle_of_repose": 30.0},
        "replicates": {"cylinder_lift.angle_of_repose": [29.0, 31.0]},
        "spread": {"cylinder_lift.angle_of_repose": 1.41},
        "relative_errors": {"cylinder_lift.angle_of_repose": 0.2},
        "targets": {"cylinder_lift.angle_of_repose": 25.0},
        "weights": {"cylinder_lift.angle_of_repose": 1.0},
        "objective_form": "relative",
    }
    record = ObjectiveRecord.from_dict(old)
    assert record.ok and record.objective == 0.25 and record.scored_with is None


def test_a_profile_without_what_crash_safety_needs_is_refused(tmp_path):
    (tmp_path / "config.yaml").write_text("cores: 2\nnolock: true\nrerun-triggers: [mtime]\n")
    with pytest.raises(
        DemcalError, match="rerun-incomplete is None; .* need rerun-incomplete: true"
    ):
        check_profile(tmp_path)
    (tmp_path / "config.yaml").write_text(
        "nolock: true\nrerun-incomplete: true\nrerun-triggers: mtime\n"
    )
    check_profile(tmp_path)
    check_profile(None)  # the local profile
    (tmp_path / "config.yaml").write_text("- nolock\n- rerun-incomplete\n")
    with pytest.raises(DemcalError, match="config.yaml holds no settings"):
        check_profile(tmp_path)
