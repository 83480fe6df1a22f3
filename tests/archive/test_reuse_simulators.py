"""Reuse and the global metamodels never take another simulator's simulations (issue 35).

Two command-engine simulators share one archive: ``sim_a`` and ``sim_b``, whose angle of
repose is 10° higher. A study on ``sim_b`` reuses none of ``sim_a``'s simulations, whatever
version it names, and its answer is its own; the same script under the same version is reused
(the control that shows the test can fail). A command engine that names no version reuses
nothing and says why.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
from helpers import run_calibration

from demcal.archive.reuse import compatible_simulations
from demcal.archive.store import Archive
from demcal.daemon.loop import Calibration
from demcal.domain.metamodel import domain_data
from demcal.errors import ConfigError
from demcal.results.records import ReusedRecord
from demcal.study.config import load_study

SIMULATOR = """\
import json, sys
sliding, rolling = float(sys.argv[1]), float(sys.argv[2])
angle = {offset} + 20.0 + 30.0 * sliding + 40.0 * rolling
json.dump({{"angle_of_repose": angle, "bulk_density": 1500.0 - 200.0 * rolling}},
          open("out.json", "w"))
"""


def write_simulator(folder, name: str, offset: float) -> str:
    path = folder / f"{name}.py"
    path.write_text(SIMULATOR.format(offset=offset))
    return str(path)


def config(name: str, script: str, version: str | None, reuse: bool, budget: int = 8) -> dict:
    """A study of ``script`` (a file in the folder the study runs in), naming ``version``."""
    engine = {
        "name": "command",
        "command": f"{sys.executable} {Path(script).resolve()} "
        "{sliding_friction_pp} {rolling_friction_pp}",
        "responses_file": "out.json",
    }
    if version is not None:
        engine["version"] = version
    return {
        "study": name,
        "engine": engine,
        "parameters": {
            "sliding_friction_pp": {"lower": 0.1, "upper": 0.9},
            "rolling_friction_pp": {"lower": 0.02, "upper": 0.3},
        },
        "targets": [
            {"scene": "cylinder_lift", "response": "angle_of_repose", "value": 40.0, "spread": 1},
            {"scene": "cylinder_lift", "response": "bulk_density", "value": 1480.0, "spread": 5},
        ],
        "replicates": 1,
        "seed": 4,
        "optimizer": {
            "max_evaluations": budget,
            "early_termination": {"enabled": False},
            "response_model": "cubic_rbf",
            "map_solutions": 0,
        },
        "calibration": {"poll_seconds": 0.001, "retries": 1},
        **({"reuse": "archive"} if reuse else {}),
    }


@pytest.fixture
def study_a(tmp_path, monkeypatch) -> Calibration:
    """A study on sim_a, version 1.0, run to its end in ``tmp_path``."""
    monkeypatch.chdir(tmp_path)
    write_simulator(tmp_path, "sim_a", 0.0)
    write_simulator(tmp_path, "sim_b", 10.0)
    return run_calibration(config("a", "sim_a.py", "1.0", reuse=False))


@pytest.mark.parametrize("version", ["1.0", "2.0"])
def test_another_simulator_is_never_reused_and_the_answer_is_its_own(study_a, version):
    b = run_calibration(config("b", "sim_b.py", version, reuse=True))
    assert ReusedRecord.read(b.files.reused).points == []
    best = json.loads(b.files.best.read_text())
    assert "reused" not in best or best["reused"] is False
    assert not best["evaluation"].startswith("a/")
    assert b.files.evaluation(best["evaluation"]).params.is_file()  # simulated by b itself


def test_the_same_script_and_version_is_reused(study_a):
    again = run_calibration(config("again", "sim_a.py", "1.0", reuse=True, budget=2))
    points = ReusedRecord.read(again.files.reused).points
    assert len(points) == study_a.optimizer.completed_evaluations() == 8


def test_an_edited_script_under_the_same_version_is_another_simulator(study_a, tmp_path):
    (tmp_path / "sim_a.py").write_text(SIMULATOR.format(offset=0.5))
    edited = run_calibration(config("edited", "sim_a.py", "1.0", reuse=True, budget=2))
    assert ReusedRecord.read(edited.files.reused).points == []


def test_the_metamodels_take_only_their_simulators_runs(study_a):
    a_again = load_study(config("domain-a", "sim_a.py", "1.0", reuse=False))
    b = load_study(config("domain-b", "sim_b.py", "1.0", reuse=False))
    with Archive(a_again.archive) as archive:
        assert len(compatible_simulations(a_again, archive)) == 8
        assert compatible_simulations(b, archive) == []
        trained_on = {key: len(data.y) for key, data in domain_data(b, archive).responses.items()}
        assert set(trained_on.values()) == {0}
        trained_on = {k: len(d.y) for k, d in domain_data(a_again, archive).responses.items()}
        assert set(trained_on.values()) == {8}


def test_a_command_without_a_version_reuses_nothing_and_says_why(study_a):
    with pytest.raises(ConfigError, match=r"reuse: 'archive' needs engine.version: name the"):
        load_study(config("c", "sim_a.py", None, reuse=True))
    unnamed = load_study(config("c", "sim_a.py", None, reuse=False))
    with Archive(unnamed.archive) as archive, pytest.raises(ConfigError, match="engine.version"):
        compatible_simulations(unnamed, archive)
