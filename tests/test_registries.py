"""Contract tests over every registered plug-in, read from the registries (no name listed by hand).

Each kind keeps its promise on a tiny seeded problem: a strategy proposes a
point inside the bounds, the same one for the same seed; a surrogate or
response model fits and predicts finite values of the right shape; a design
gives n points in the unit box; an engine is an ``Engine`` under its own
name; a scene has a driver for each engine it claims and none for the others.
"""

import numpy as np
import pytest

from demcal.engines import ENGINES
from demcal.engines.base import Engine
from demcal.optimizer import Optimizer, Strategy
from demcal.optimizer.designs import initial_design
from demcal.optimizer.objective import ResponseObjective, Target
from demcal.optimizer.registry import DESIGNS, RESPONSE_MODELS, STRATEGIES, SURROGATES
from demcal.optimizer.surrogates.base import ResponseModel, Surrogate
from demcal.plugins import Entry, Registry, UnknownPlugin
from demcal.scenes import SCENES, Scene

REGISTRIES = [STRATEGIES, SURROGATES, RESPONSE_MODELS, DESIGNS, ENGINES, SCENES]
LOWER, UPPER = [0.1, 0.02], [0.9, 0.3]
TARGETS = (Target("s", "a", 2.0, spread=0.1), Target("s", "b", 1.0, spread=0.1))


def responses(x) -> dict[str, list[float]]:
    """Two smooth responses of the parameters, one replicate each."""
    x0, x1 = x
    return {"s.a": [1.0 + 2.0 * x0 + 3.0 * x1], "s.b": [0.5 + x0 * x1 + x1]}


def first_adaptive_proposal(strategy: str, seed: int):
    """The first point ``strategy`` chooses once the initial design is told."""
    optimizer = Optimizer(
        LOWER,
        UPPER,
        {
            "strategy": strategy,
            "max_evaluations": 20,
            "response_model": "cubic_rbf",
            "kriging_restarts": 1,
            "design_tries": 2,
        },
        seed=seed,
        objective=ResponseObjective(TARGETS),
    )
    while optimizer.design_queue:
        (proposal,) = optimizer.ask()
        optimizer.tell(proposal.id, responses=responses(proposal.x))
    (proposal,) = optimizer.ask()
    assert not proposal.in_initial_design
    return proposal.x


@pytest.mark.parametrize("registry", REGISTRIES, ids=lambda registry: registry.kind)
def test_an_unknown_name_is_refused_with_the_known_names(registry):
    with pytest.raises(UnknownPlugin) as error:
        registry["no such name"]
    assert str(error.value) == (
        f"unknown {registry.kind} 'no such name'; known: {', '.join(registry)}"
    )


def test_a_name_is_registered_once():
    registry = Registry("thing", {"one": Entry(object)})
    registry.register("two", Entry("demcal.plugins:Entry"))
    assert registry.load("two") is Entry and registry.load("one") is object
    with pytest.raises(ValueError, match="thing 'one' is already registered"):
        registry.register("one", Entry(int))


@pytest.mark.parametrize("name", list(STRATEGIES))
def test_each_strategy_proposes_a_point_in_the_bounds_the_same_for_the_same_seed(name):
    entry = STRATEGIES[name]
    assert issubclass(entry.load(), Strategy)
    assert entry.surrogate in SURROGATES and set(entry.surrogates or ()) <= set(SURROGATES)
    x = first_adaptive_proposal(name, seed=4)
    assert np.all(np.asarray(x) >= LOWER) and np.all(np.asarray(x) <= UPPER)
    assert first_adaptive_proposal(name, seed=4) == x


@pytest.fixture
def data():
    rng = np.random.default_rng(5)
    x = rng.random((12, 2))
    return x, np.sin(3 * x[:, 0]) + x[:, 1] ** 2, np.full(12, 1e-4), rng.random((5, 2))


@pytest.mark.parametrize("name", list(SURROGATES))
def test_each_surrogate_fits_and_predicts_finite_values(name, data):
    x, y, variance, probe = data
    model = SURROGATES.load(name).create(1e-7, restarts=1, seed=0)
    assert isinstance(model, Surrogate)
    predicted = model.fit(x, y, variance).predict(probe)
    assert predicted.shape == (5,) and np.all(np.isfinite(predicted))


@pytest.mark.parametrize("name", list(RESPONSE_MODELS))
def test_each_response_model_fits_and_predicts_a_finite_mean_and_sd(name, data):
    x, y, variance, probe = data
    model = RESPONSE_MODELS.load(name).create(1e-7, restarts=1, seed=0)
    assert isinstance(model, ResponseModel) and not model.caps_large_values
    model.fit(x, y, variance)
    mean, sd = model.predict(probe), model.predict_std(probe)
    assert mean.shape == sd.shape == (5,)
    assert np.all(np.isfinite(mean)) and np.all(np.isfinite(sd)) and np.all(sd >= 0.0)


@pytest.mark.parametrize("name", list(DESIGNS))
def test_each_design_gives_n_points_in_the_unit_box_the_same_for_the_same_seed(name):
    design = DESIGNS.load(name)(7, 3, np.random.default_rng(6))
    assert design.shape == (7, 3) and np.all((design >= 0.0) & (design <= 1.0))
    chosen = initial_design(name, 7, 3, np.random.default_rng(6), tries=3)
    assert chosen.shape == (7, 3) and np.all((chosen >= 0.0) & (chosen <= 1.0))
    assert np.array_equal(chosen, initial_design(name, 7, 3, np.random.default_rng(6), tries=3))


@pytest.mark.parametrize("name", list(ENGINES))
def test_each_engine_is_an_engine_under_its_registered_name(name):
    engine = ENGINES.load(name)
    assert issubclass(engine, Engine) and engine.name == name


@pytest.mark.parametrize("name", list(SCENES))
def test_each_scene_is_declared_under_its_name_and_claims_only_registered_engines(name):
    scene = SCENES.load(name)
    assert isinstance(scene, Scene) and scene.name == name
    assert set(scene.drivers) <= set(ENGINES)


@pytest.mark.parametrize("engine", list(ENGINES))
@pytest.mark.parametrize("scene", list(SCENES))
def test_each_scene_has_a_driver_for_each_engine_it_claims_and_none_for_the_others(scene, engine):
    declared = SCENES.load(scene)
    driver = declared.driver(engine)  # imports the driver's module
    if engine in declared.drivers or engine == "analytic":
        assert callable(driver)
    else:
        assert driver is None
