"""``demcal advise`` end to end on the analytic engine (issue 39, items 1-3).

A study that targets the cylinder lift's angle of repose alone leaves a curve of sliding and
rolling friction open. Of the candidates, the calibration device's slide time depends on the
particle-wall friction alone, which the study fixes: it cannot narrow anything, and must rank
last (or tied last). The joint study file the advice writes must find every advised set in
the archive."""

from __future__ import annotations

import copy
import json
import os
import subprocess
import sys

import pytest
import yaml
from helpers import ANALYTIC_STUDY

from demcal.archive.reuse import reused_points
from demcal.archive.store import Archive
from demcal.study.config import load_study_file

STUDY = {
    **copy.deepcopy(ANALYTIC_STUDY),
    "study": "repose",
    "engine": {"name": "analytic", "noise": 0.005},
    "targets": [
        {
            "scene": "cylinder_lift",
            "response": "angle_of_repose",
            "value": 20.0,
            "unit": "deg",
            "spread": 0.5,
        }
    ],
    "replicates": 1,
    "optimizer": {"max_evaluations": 14, "map_solutions": 6},
}


def demcal(folder, *args):
    done = subprocess.run(
        [sys.executable, "-m", "demcal.cli", *args],
        cwd=folder,
        capture_output=True,
        text=True,
        timeout=600,
        stdin=subprocess.DEVNULL,
        env={**os.environ, "TQDM_DISABLE": "1"},
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return done.stdout


@pytest.mark.slow
def test_advise_ranks_a_test_that_moves_nothing_open_last_and_its_joint_study_reuses_the_runs(
    tmp_path, monkeypatch
):
    (tmp_path / "study.yaml").write_text(yaml.safe_dump(STUDY, sort_keys=False))
    demcal(tmp_path, "run", "study.yaml")
    out = demcal(tmp_path, "advise", "study.yaml", "--tests", "calibration_device", "shear_box")
    advice = json.loads((tmp_path / "results/repose/advice/advice.json").read_text())
    ranking = advice["ranking"]
    assert advice["sets"] == 5 and len(ranking) == 5
    first = ranking[0]
    (slide,) = [r for r in ranking if r["response"] == "slide_time"]
    assert slide["score"] == pytest.approx(max(r["score"] for r in ranking))  # last, or tied
    for name, now in slide["share_now"].items():
        assert slide["expected_share"][name] == pytest.approx(now, abs=0.03)
    assert (
        first["expected_share"]["rolling_friction_pp"]
        < 0.8 * first["share_now"]["rolling_friction_pp"]
    )
    assert f"1. {first['sentence']}" in out
    assert (tmp_path / "results/repose/advice/advice.png").stat().st_size > 10_000

    joint_file = tmp_path / first["joint_study"]
    joint = yaml.safe_load(joint_file.read_text())
    added = joint["targets"][-1]
    assert (added["scene"], added["response"]) == (first["scene"], first["response"])
    assert "value" not in added and joint["reuse"] == "archive"
    added["value"] = 1.0  # any measurement: reuse does not depend on it
    joint_file.write_text(yaml.safe_dump(joint, sort_keys=False))
    monkeypatch.chdir(tmp_path)
    study = load_study_file(joint_file)
    with Archive(study.archive) as archive:
        points = reused_points(study, archive)
    assert len(points.points) >= advice["sets"]  # every advised set has both tests

    # the verdicts now name the advice
    assert "advised next (demcal advise): measuring" in demcal(tmp_path, "solutions", "repose")
