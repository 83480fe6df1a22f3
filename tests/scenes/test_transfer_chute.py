"""Transfer chute (issue 24, item 3): geometry checks, its measures, the analytic stand-in, a
design study of it, and tiny LAMMPS runs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from demcal.engines.base import RunMonitor, SimulationJob
from demcal.engines.lammps import LammpsEngine
from demcal.errors import ConfigError, SimulationFailed
from demcal.physics.catalogue import CATALOG
from demcal.reporting.figures import answer_histories, plot_answer_history
from demcal.results.records import BestRecord, SimulationRecord, Status
from demcal.results.storage import read_partial
from demcal.scenes import SCENES
from demcal.scenes.transfer_chute import DESIGN_SETTINGS, chute_geometry, expected_particle_mass
from demcal.scenes.transfer_chute.lammps import flow_responses, window_rate
from demcal.study.config import load_study
from demcal.study.model import freeze

SCENE = SCENES.load("transfer_chute")
MATERIAL = {name: spec.default for name, spec in CATALOG.items()}


def settings(**given):
    return SCENE.resolve_settings(given, "scenes.transfer_chute.settings")


# -- measures and geometry ------------------------------------------------------
def test_window_rate_is_the_mass_delivered_per_second_inside_the_window():
    times = np.arange(7) * 0.5
    delivered = np.array([0.0, 0.0, 5.0, 15.0, 25.0, 35.0, 45.0])  # 20 kg/s from t = 1 s
    assert window_rate(times, delivered, 1.0, 3.0) == pytest.approx(20.0)
    with pytest.raises(SimulationFailed, match="fewer than two counts"):
        window_rate(times, delivered, 2.9, 3.0)


def test_flow_responses_follow_from_the_two_flows():
    assert flow_responses(30.0, 10.0) == {
        "mass_flow_left": 30.0,
        "mass_flow_right": 10.0,
        "flow_difference": 20.0,
        "split": 0.75,
    }
    with pytest.raises(SimulationFailed, match="no material reached the chutes"):
        flow_responses(0.0, 0.0)


def test_the_tilt_moves_the_outlet_to_the_right_for_a_positive_angle():
    g = chute_geometry(settings(funnel_angle=6.0, funnel_y=0.1))
    assert g.outlet_y == pytest.approx(0.1 + 0.5 * math.sin(math.radians(6.0)))
    assert g.outlet_z == pytest.approx(1.5 - 0.5 * math.cos(math.radians(6.0)))


def test_the_expected_particle_mass_matches_a_large_sample():
    from demcal.physics.psd import sample_diameters

    s = settings(sigma_ln=0.4, psd_truncation=1.5)
    d = sample_diameters(200_000, s["d50"], 0.4, 1.5, np.random.default_rng(1))
    sampled = float(np.mean(2750.0 * math.pi / 6.0 * d**3))
    assert expected_particle_mass(s, 2750.0) == pytest.approx(sampled, rel=0.01)


@pytest.mark.parametrize(
    "given, message",
    [
        (
            {"funnel_outlet_radius": 0.1},
            r"funnel_outlet_radius: 0.1 m; the outlet must be at least",
        ),
        ({"funnel_outlet_radius": 0.6}, r"funnel_outlet_radius: 0.6 m is not below funnel_top"),
        ({"steady_from": 3.0}, r"steady_from: 3 s leaves no steady window"),
        ({"funnel_z": 0.6}, r"funnel_height: the funnel's rim reaches z = 2.1 m, into the belt"),
        ({"funnel_z": -0.8}, r"divider_height: the funnel's outlet comes down to z = 0.2 m"),
        ({"belt_speed": 12.0}, r"belt_speed: 12.0 is outside the allowed range"),
    ],
)
def test_bad_settings_name_field_and_range(given, message):
    with pytest.raises(ConfigError, match=message):
        settings(**given)


# -- the analytic stand-in and a design study -----------------------------------
def test_the_stand_in_conserves_the_feed_and_moves_the_split_with_the_funnel():
    left = SCENE.analytic_model(MATERIAL, settings(funnel_y=-0.3))
    right = SCENE.analytic_model(MATERIAL, settings(funnel_y=0.3))
    for flows in (left, right):
        assert flows["mass_flow_left"] + flows["mass_flow_right"] == pytest.approx(150.0)
        assert flows["flow_difference"] == pytest.approx(
            flows["mass_flow_left"] - flows["mass_flow_right"]
        )
    assert left["split"] > 0.9 and right["split"] < 0.1


CHUTE_DESIGN = {
    "study": "chute",
    "engine": {"name": "analytic", "noise": 0.0},
    "parameters": {
        "funnel_angle": {"lower": -6.0, "upper": 6.0},
        "funnel_y": {"lower": -0.4, "upper": 0.4},
        "funnel_z": {"lower": -0.4, "upper": 0.4},
        "belt_speed": {"lower": 3.0, "upper": 4.0},
    },
    "targets": [{"scene": "transfer_chute", "response": "flow_difference", "value": 0.0}],
}


def test_a_design_study_frees_the_thesis_design_variables_with_units():
    study = load_study(CHUTE_DESIGN)
    assert [p.name for p in study.free] == list(DESIGN_SETTINGS)
    assert [p.spec.unit for p in study.free] == ["deg", "m", "m", "m/s"]
    point = {"funnel_angle": -1.9, "funnel_y": -0.02, "funnel_z": 0.08, "belt_speed": 3.7}
    assert study.settings_for("transfer_chute", point)["belt_speed"] == 3.7
    assert set(study.parameters_for(point)) == set(study.fixed)  # no setting in the material


def test_the_thesis_box_is_refused_where_a_corner_breaks_the_geometry():
    config = {**CHUTE_DESIGN, "parameters": {"funnel_z": {"lower": -0.9, "upper": 0.4}}}
    with pytest.raises(ConfigError, match=r"at funnel_z = -0.9, a corner of the free bounds"):
        load_study(config)


# -- real LAMMPS on a tiny chute --------------------------------------------------
#: A short feed of few particles: seconds per LAMMPS run.
TINY = {"feed_rate": 40.0, "feed_time": 1.6, "steady_from": 1.2, "sample_interval": 0.05}


def tiny_job(tmp_path, **given):
    return SimulationJob(
        scene="transfer_chute",
        parameters={**MATERIAL, "youngs_modulus": 5.0e7},
        settings=settings(**{**TINY, **given}),
        seed=5,
        responses=list(SCENE.responses),
        timestep_fraction=0.25,
        workdir=str(tmp_path),
        stop_file=str(tmp_path / "STOP"),
    )


@pytest.mark.lammps
@pytest.mark.slow
def test_a_tiny_chute_delivers_what_it_is_fed_and_estimates_early(tmp_path):
    job = tiny_job(tmp_path)
    result = LammpsEngine().run(job, RunMonitor(job), SCENE.driver("lammps"))
    assert result.status == Status.OK, result.reason
    m = result.measurements
    fed = job.settings["feed_rate"] * job.settings["feed_time"]
    particle = expected_particle_mass(job.settings, job.parameters["particle_density"])
    assert fed - 5 * particle < m["fed_mass"] <= fed + particle
    delivered = result.arrays["delivered_left"][-1] + result.arrays["delivered_right"][-1]
    assert 0.0 < delivered <= m["fed_mass"] + 1e-9
    assert m["mass_flow_left"] + m["mass_flow_right"] == pytest.approx(
        m["flow_difference"] + 2 * m["mass_flow_right"]
    )
    assert 0.0 <= m["split"] <= 1.0
    assert 0.3 * 40.0 < m["mass_flow_left"] + m["mass_flow_right"] < 1.5 * 40.0
    estimates = {row["response"] for row in read_partial(job.partial_file) if row["response"]}
    assert estimates == set(SCENE.responses)


@pytest.mark.lammps
@pytest.mark.slow
def test_moving_the_funnel_moves_the_flow(tmp_path):
    """The funnel far to the right takes the stream to the right; far to the left, the stream
    that it throws back from its far wall goes left."""
    engine = LammpsEngine()
    splits = {}
    for offset in (-0.4, 0.4):
        job = tiny_job(tmp_path / str(offset), funnel_y=offset, funnel_angle=0.0)
        result = engine.run(job, RunMonitor(job), SCENE.driver("lammps"))
        assert result.status == Status.OK, result.reason
        splits[offset] = result.measurements["split"]
    assert splits[-0.4] > 0.8 and splits[0.4] < 0.2


# -- the report's figure of the answer over time -----------------------------------
def saved_run(study, evaluation: str, rate_left: float, rate_right: float) -> None:
    """A finished replicate of ``evaluation`` with a steady delivery, as the driver saves it."""
    files = study.files.evaluation(evaluation).replicate("transfer_chute", 0)
    files.dir.mkdir(parents=True)
    times = np.arange(0, 3.01, 0.05)
    np.savez(
        files.state,
        delivery_time=times,
        delivered_left=rate_left * times,
        delivered_right=rate_right * times,
    )
    SimulationRecord(
        evaluation,
        "transfer_chute",
        0,
        "lammps",
        "x",
        study.settings["transfer_chute"],
        0.25,
        ["flow_difference"],
        0.0,
        Status.OK,
        state_file="state.npz",
    ).write(files.simulation)


def test_the_answer_over_time_gathers_its_runs_and_confirmations(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    study = freeze(load_study(CHUTE_DESIGN))
    assert study.keeps_history
    saved_run(study, "e0004", 70.0, 80.0)
    saved_run(study, "e0011", 74.0, 76.0)
    best = BestRecord(
        "e0004", {}, objective=1.0, confirmation={"of": "e0004", "evaluations": ["e0011", "e0012"]}
    )
    series = answer_histories(study, best)  # e0012 has no saved run: skipped
    assert sorted(series) == ["transfer_chute.mass_flow_left", "transfer_chute.mass_flow_right"]
    left = series["transfer_chute.mass_flow_left"]
    assert len(left) == 2
    assert left[0][1] == pytest.approx(70.0) and left[1][1] == pytest.approx(74.0)
    plot_answer_history(study, best, tmp_path / "answer.png")
    plot_answer_history(study, None, tmp_path / "none.png")
    assert (tmp_path / "answer.png").stat().st_size > 0 and (tmp_path / "none.png").exists()
