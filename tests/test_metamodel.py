"""Global metamodels of a material domain (issue 22, item 2) on the analytic engine: trained
on one campaign's archived simulations, validated on another's."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import yaml
from conftest import ANALYTIC_STUDY

from demcal import metamodel
from demcal.archive.record import ArchivedSimulation, Quantity
from demcal.archive.store import Archive
from demcal.cli import main
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
    random LHS points) in its archive; gplearn kept small so that the test is quick."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(metamodel, "POPULATION", 400)
    monkeypatch.setattr(metamodel, "GENERATIONS", 8)
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


def test_validating_on_trained_simulations_or_without_any_is_refused(domain, capsys):
    assert main(["metamodel", "build", "domain.yaml", "--model", "kriging"]) == 0
    assert main(["metamodel", "validate", "domain.yaml", "--holdout", "check"]) == 2
    assert "the models were trained on its simulations" in capsys.readouterr().err
    assert main(["metamodel", "validate", "domain.yaml"]) == 2
    assert "give --holdout STUDY" in capsys.readouterr().err
