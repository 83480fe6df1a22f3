"""Global metamodels of a material domain (issue 22, item 2) on the analytic engine: trained
on one campaign's archived simulations, validated on another's."""

from __future__ import annotations

import copy
import dataclasses
import json
import pickle
import re

import numpy as np
import pytest
import yaml
from helpers import ANALYTIC_STUDY, demcal, finish

from demcal.archive.simulation import ArchivedSimulation, Quantity, digest
from demcal.archive.store import Archive
from demcal.cli import main
from demcal.domain import metamodel
from demcal.optimizer.designs import fssf_f, latin_hypercube
from demcal.results.records import Status
from demcal.study.config import load_study
from demcal.study.model import Study, freeze

DOMAIN = {
    **copy.deepcopy(ANALYTIC_STUDY),
    "study": "domain",
    "parameters": {
        "sliding_friction_pp": {"lower": 0.1, "upper": 0.9},
        "rolling_friction_pp": {"lower": 0.02, "upper": 0.3},
        "particle_density": {"lower": 2000.0, "upper": 3000.0},
        "sigma_ln": {"lower": 0.0, "upper": 0.1},
    },
}


def simulated(study: Study, name: str, unit: np.ndarray) -> list[ArchivedSimulation]:
    """What the analytic engine's campaign ``name`` would archive at the unit-box points."""
    records = []
    for index, row in enumerate(unit):
        point = {p.name: p.lower + u * (p.upper - p.lower) for p, u in zip(study.free, row)}
        parameters = study.parameters_for(point)
        settings = study.settings_for("cylinder_lift", point)
        responses = study.scenes["cylinder_lift"].analytic_model(parameters, settings)
        records.append(
            ArchivedSimulation(
                study=name,
                evaluation=f"e{index:04d}",
                scene="cylinder_lift",
                replicate=0,
                engine="analytic",
                engine_version=study.engine.version(),
                simulator=digest(study.simulator("cylinder_lift")),
                settings=settings,
                timestep_fraction=study.timestep_fraction,
                status=Status.OK,
                seed=index,
                parameters={
                    **{n: Quantity(v, "") for n, v in parameters.items()},
                    "d50": Quantity(settings["d50"], "m"),
                    "sigma_ln": Quantity(settings["sigma_ln"], "-"),
                },
                free=frozenset(point),
                responses={n: Quantity(v, "") for n, v in responses.items()},
                final=dict.fromkeys(responses, True),
            )
        )
    return records


@pytest.fixture
def domain(tmp_path, monkeypatch) -> Study:
    """The domain's study with a training campaign (60 FSSF-f points) and a held-out one (20
    random LHS points) in its archive; gplearn and the Kriging search kept small so that the
    test is quick."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(metamodel, "POPULATION", 400)
    monkeypatch.setattr(metamodel, "GENERATIONS", 8)
    monkeypatch.setattr(metamodel, "KRIGING_RESTARTS", 1)
    study = freeze(load_study(copy.deepcopy(DOMAIN)))
    with Archive(study.archive) as archive:
        archive.add(simulated(study, "domain", fssf_f(60, 4, np.random.default_rng(1))))
        archive.add(simulated(study, "check", latin_hypercube(20, 4, np.random.default_rng(2))))
    (tmp_path / "domain.yaml").write_text(yaml.safe_dump(DOMAIN))
    return study


def test_models_trained_on_a_campaign_predict_another(domain, capsys):
    assert main(["metamodel", "build", "domain.yaml", "--holdout", "check"]) == 0
    built = capsys.readouterr().out
    assert "cylinder_lift.angle_of_repose: trained on 60 simulations" in built
    assert (
        "symbolic: cylinder_lift.angle_of_repose = " in built and "x_sliding_friction_pp" in built
    )
    assert main(["metamodel", "validate", "domain.yaml", "--holdout", "check"]) == 0
    table = capsys.readouterr().out
    rows = {
        tuple(cells[1:3]): float(cells[4])
        for line in table.splitlines()
        if line.startswith("| cylinder_lift")
        for cells in [[c.strip() for c in line.split("|")]]
    }
    assert set(rows) == {
        (f"cylinder_lift.{r}", k)
        for r in ("angle_of_repose", "bulk_density")
        for k in ("kriging", "symbolic")
    }
    # a smooth closed form: Kriging nearly exact, a short evolution of programs less so
    assert rows[("cylinder_lift.angle_of_repose", "kriging")] > 0.99
    assert rows[("cylinder_lift.bulk_density", "kriging")] > 0.99
    assert min(rows.values()) > 0.5
    assert (domain.files.dir / "metamodels" / "validation.html").read_text().count("<img") == 4


def test_show_says_when_the_archive_has_moved_on(domain, capsys):
    assert main(["metamodel", "build", "domain.yaml", "--model", "kriging"]) == 0
    capsys.readouterr()
    assert main(["metamodel", "show", "domain.yaml"]) == 0
    assert "stale" not in capsys.readouterr().out
    with Archive(domain.archive) as archive:
        archive.add(simulated(domain, "later", np.array([[0.5, 0.5, 0.5, 0.5]])))
    assert main(["metamodel", "show", "domain.yaml"]) == 0
    assert "stale: the archive's simulations of the domain have changed" in capsys.readouterr().out


def test_models_of_an_earlier_format_are_built_again(domain, capsys):
    assert main(["metamodel", "build", "domain.yaml", "--model", "kriging"]) == 0
    path = domain.files.metamodels
    models = metamodel.load(domain)
    del models.__dict__["format"]  # as pickled before the field existed
    path.write_bytes(pickle.dumps(models))
    capsys.readouterr()
    assert main(["metamodel", "show", "domain.yaml"]) == 2
    assert "built by an earlier demcal" in capsys.readouterr().err


def test_ctrl_c_during_a_build_is_one_line(domain, monkeypatch, capsys):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(metamodel, "build", interrupted)
    assert main(["metamodel", "build", "domain.yaml"]) == 130
    assert capsys.readouterr().err == "demcal: interrupted; run the same command again\n"


def test_validating_on_trained_simulations_or_without_any_is_refused(domain, capsys):
    assert main(["metamodel", "build", "domain.yaml", "--model", "kriging"]) == 0
    assert main(["metamodel", "validate", "domain.yaml", "--holdout", "check"]) == 2
    assert "the models were not built with it held out" in capsys.readouterr().err
    assert main(["metamodel", "validate", "domain.yaml"]) == 2
    assert "give --holdout STUDY" in capsys.readouterr().err


TRUTH = {"sliding_friction_pp": 0.45, "rolling_friction_pp": 0.12, "particle_density": 2500.0}


def material(**changes) -> dict:
    """Gravel-like material of the domain: density measured (held), sigma_ln from a sieve
    analysis (held), the two frictions free; targets the closed form's responses at TRUTH."""
    config = copy.deepcopy(DOMAIN)
    config["study"] = "material"
    config["parameters"] = {
        "sliding_friction_pp": {"lower": 0.1, "upper": 0.9},
        "rolling_friction_pp": {"lower": 0.02, "upper": 0.3},
    }
    config["fixed"] = {**config["fixed"], "particle_density": 2500.0}
    config["scenes"] = {"cylinder_lift": {"settings": {"sigma_ln": 0.05}}}
    study = load_study(config)
    settings = study.settings_for("cylinder_lift", {})
    responses = study.scenes["cylinder_lift"].analytic_model({**study.fixed, **TRUTH}, settings)
    config["targets"] = [
        {"scene": "cylinder_lift", "response": r, "value": v, "spread": 0.005 * v}
        for r, v in responses.items()
    ]
    for key, value in changes.items():
        config[key] = {**config[key], **value} if isinstance(value, dict) else value
    return config


def test_a_material_is_calibrated_on_the_models_without_simulating(domain, tmp_path, capsys):
    assert main(["metamodel", "build", "domain.yaml", "--model", "kriging"]) == 0
    (tmp_path / "material.yaml").write_text(yaml.safe_dump(material()))
    capsys.readouterr()
    assert (
        main(["calibrate-metamodel", "material.yaml", "--domain", "domain.yaml", "--starts", "8"])
        == 0
    )
    out = capsys.readouterr().out
    assert "no simulation" in out and "held: particle_density = 2500, sigma_ln = 0.05" in out
    best = out.split("optimum 1 (")[1].splitlines()[0]
    found = {
        name: float(value)
        for name, value in (part.split(" = ") for part in best.split("): ")[1].split(", "))
    }
    assert found["sliding_friction_pp"] == pytest.approx(TRUTH["sliding_friction_pp"], abs=0.03)
    assert found["rolling_friction_pp"] == pytest.approx(TRUTH["rolling_friction_pp"], abs=0.015)
    assert not (tmp_path / "results" / "material" / "evals").exists()  # nothing simulated
    # the solution set on the global models holds the truth, and says what the targets pin
    folder = tmp_path / "results" / "material" / "metamodel" / "kriging"
    summary = strict_json(folder / "calibration.json")
    assert summary["solution_set"]["likely"] > 0 and summary["validation"] is None
    for verdict in summary["solution_set"]["verdicts"]:
        assert verdict["low"] <= TRUTH[verdict["name"]] <= verdict["high"], verdict
        assert verdict["verdict"] in ("pinned", "partly identified"), verdict
        assert verdict["sentence"] in out
    assert (folder / "solution_space.png").stat().st_size
    table = (folder / "solutions.csv").read_text().splitlines()
    assert set(table[0].split(",")[:3]) == {*TRUTH, "membership_probability"} - {"particle_density"}
    other = material()
    other["targets"] = [{"scene": "cylinder_lift", "response": "angle_of_repose", "value": 20.0}]
    other["scenes"]["cylinder_lift"]["settings"]["aor_method"] = "height_radius"
    (tmp_path / "other.yaml").write_text(yaml.safe_dump(other))
    assert main(["calibrate-metamodel", "other.yaml", "--domain", "domain.yaml"]) == 2
    assert "settings.aor_method: the domain's models were trained at flank_fit" in (
        capsys.readouterr().err
    )


def strict_json(path):
    """A JSON file read by the standard: a NaN or Infinity in it fails the test."""

    def refuse(constant):
        raise AssertionError(f"{path}: {constant} is not JSON")

    return json.loads(path.read_text(), parse_constant=refuse)


def test_symbolic_models_and_out_of_reach_targets_say_what_they_can(domain, tmp_path, capsys):
    """Symbolic models (no posterior: their RMSE widens the bands) still give a set holding the
    truth; a target no material of the domain reaches gives no set, says so, and a summary
    with nulls where there are no spans."""
    assert main(["metamodel", "build", "domain.yaml", "--model", "symbolic"]) == 0
    (tmp_path / "material.yaml").write_text(yaml.safe_dump(material()))
    assert (
        main(
            calibrate := [
                "calibrate-metamodel",
                "material.yaml",
                "--domain",
                "domain.yaml",
                "--model",
                "symbolic",
                "--starts",
                "4",
            ]
        )
        == 0
    )
    summary = strict_json(tmp_path / "results/material/metamodel/symbolic/calibration.json")
    assert summary["solution_set"]["likely"] > 0
    for verdict in summary["solution_set"]["verdicts"]:
        assert verdict["low"] <= TRUTH[verdict["name"]] <= verdict["high"], verdict
    unreachable = material()
    unreachable["targets"][0]["value"] = 80.0  # degrees: no friction of the domain gets there
    (tmp_path / "material.yaml").write_text(yaml.safe_dump(unreachable))
    capsys.readouterr()
    assert main(calibrate) == 0
    out = capsys.readouterr().out
    assert "they lie outside what the domain gives for this material's held values" in out
    summary = strict_json(tmp_path / "results/material/metamodel/symbolic/calibration.json")
    assert summary["solution_set"]["likely"] == 0
    assert all(v["low"] is None for v in summary["solution_set"]["verdicts"])


@pytest.mark.parametrize(
    "changes, message",
    [
        (
            {"parameters": {"sliding_friction_pw": {"lower": 0.2, "upper": 0.4}}},
            r"parameters.sliding_friction_pw: not an input of the domain's models",
        ),
        (
            {"scenes": {"cylinder_lift": {"settings": {"sigma_ln": 0.3}}}},
            r"scenes.cylinder_lift.settings.sigma_ln: 0.3 is outside the domain \[0, 0.1\]",
        ),
        (
            {"fixed": {"restitution_pp": 0.6}},
            r"fixed.restitution_pp: the domain's models were trained at 0.5, the material "
            r"gives 0.6",
        ),
        (
            {"scenes": {"cylinder_lift": {"settings": {"sigma_ln": 0.05, "lift_speed": 0.02}}}},
            r"scenes.cylinder_lift.settings.lift_speed: the domain's models were trained at "
            r"0.01, the material gives 0.02",
        ),
        (
            {"timestep_fraction": 0.2},
            r"timestep_fraction: the domain's models were trained at 0.25, the material gives 0.2",
        ),
    ],
    ids=["not_an_input", "outside", "other_fixed", "other_setting", "other_time_step"],
)
def test_a_material_the_models_do_not_cover_is_refused(domain, tmp_path, capsys, changes, message):
    (tmp_path / "material.yaml").write_text(yaml.safe_dump(material(**changes)))
    capsys.readouterr()
    assert main(["calibrate-metamodel", "material.yaml", "--domain", "domain.yaml"]) == 2
    assert re.search(message, capsys.readouterr().err)


@pytest.mark.slow
def test_the_answer_is_validated_by_simulation(domain, tmp_path):
    """--validate 2: two simulations at the answer (Snakemake, analytic engine), their errors
    against the targets and the models' predictions."""
    assert main(["metamodel", "build", "domain.yaml", "--model", "kriging"]) == 0
    config = material()
    config["engine"] = {"name": "analytic", "noise": 0.0}
    (tmp_path / "material.yaml").write_text(yaml.safe_dump(config))
    out = finish(
        demcal(
            tmp_path,
            "calibrate-metamodel",
            "material.yaml",
            "--domain",
            "domain.yaml",
            "--starts",
            "8",
            "--validate",
            "2",
        )
    )
    assert "validation: 4 of 4 simulations finished (4 ok)" in out  # 2 replicates each
    for line in [line for line in out.splitlines() if "% against the target" in line]:
        error = float(line.split("runs), ")[1].split(" %")[0])
        assert abs(error) < 1.0, line


def test_models_saved_before_the_package_moved_still_load(tmp_path, monkeypatch):
    """Models pickled when they lived in demcal/metamodel.py (KrigingModel) load as today's."""
    monkeypatch.chdir(tmp_path)
    study = freeze(load_study(copy.deepcopy(ANALYTIC_STUDY)))
    models = metamodel.Metamodels(
        ["sliding_friction_pp"],
        np.array([0.1]),
        np.array([0.9]),
        {"cylinder_lift.angle_of_repose": {"kriging": metamodel.KrigingMetamodel(None)}},
        {"cylinder_lift.angle_of_repose": 12},
        "fingerprint",
        format=metamodel.FORMAT,
    )
    saved = pickle.dumps(models, protocol=0)  # text opcodes: the class paths can be renamed
    for new, old in ((b"Metamodels", b"Metamodels"), (b"KrigingMetamodel", b"KrigingModel")):
        saved = saved.replace(b"demcal.domain.metamodel\n" + new, b"demcal.metamodel\n" + old)
    assert b"demcal.domain" not in saved
    study.files.metamodels.parent.mkdir(parents=True)
    study.files.metamodels.write_bytes(saved)
    loaded = metamodel.load(study)
    assert isinstance(loaded, metamodel.Metamodels) and loaded.training_size == models.training_size
    kriging = loaded.models["cylinder_lift.angle_of_repose"]["kriging"]
    assert isinstance(kriging, metamodel.KrigingMetamodel)


def test_a_multi_fidelity_model_learns_a_domain_from_few_fine_runs(tmp_path, monkeypatch, capsys):
    """Issue 38, item 6: 10 fine and 80 coarse runs (a coarse level scaled by 0.9, the angle
    shifted by 3 deg) predict held-out fine runs better than Kriging of the 10 fine ones."""
    from demcal.engines.analytic import distorted

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(metamodel, "KRIGING_RESTARTS", 1)
    level = {"scale": 0.9, "bias": {"angle_of_repose": 3.0}}
    config = {**copy.deepcopy(DOMAIN), "fidelities": {"coarse": {"engine": level}}}
    study = freeze(load_study(config))
    coarse = [
        dataclasses.replace(
            record,
            simulator=digest(study.simulator("cylinder_lift", "coarse")),
            fidelity="coarse",
            responses={
                name: Quantity(value, "")
                for name, value in distorted(
                    {n: q.value for n, q in record.responses.items()},
                    {n: q.value for n, q in record.parameters.items()},
                    level,
                ).items()
            },
        )
        for record in simulated(study, "coarse-domain", fssf_f(80, 4, np.random.default_rng(3)))
    ]
    with Archive(study.archive) as archive:
        archive.add(simulated(study, "domain", fssf_f(10, 4, np.random.default_rng(1))))
        archive.add(coarse)
        archive.add(simulated(study, "check", latin_hypercube(20, 4, np.random.default_rng(2))))
    (tmp_path / "domain.yaml").write_text(yaml.safe_dump(config))
    assert main(["metamodel", "build", "domain.yaml", "--model", "multi_fidelity"]) == 2
    assert "--model multi_fidelity: name the cheaper level" in capsys.readouterr().err
    assert main(["metamodel", "build", "domain.yaml", "--fidelity", "nope"]) == 2
    assert "--fidelity nope: not a cheaper level of the study (coarse)" in capsys.readouterr().err
    build = ["metamodel", "build", "domain.yaml", "--holdout", "check", "--fidelity", "coarse"]
    assert main([*build, "--model", "kriging", "multi_fidelity"]) == 0
    assert "multi-fidelity Kriging (coarse -> fine, scale" in capsys.readouterr().out
    assert main(["metamodel", "validate", "domain.yaml", "--holdout", "check"]) == 0
    rows = {
        tuple(cells[1:3]): float(cells[4])
        for line in capsys.readouterr().out.splitlines()
        if line.startswith("| cylinder_lift")
        for cells in [[c.strip() for c in line.split("|")]]
    }
    angle = "cylinder_lift.angle_of_repose"
    assert rows[(angle, "multi_fidelity")] > 0.99
    assert rows[(angle, "multi_fidelity")] > rows[(angle, "kriging")]
