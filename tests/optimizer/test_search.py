import numpy as np
import pytest

from demcal.optimizer import History, Optimizer, OptimizerSettings, Strategy, register_strategy
from demcal.optimizer.registry import STRATEGIES, strategy_class
from demcal.optimizer.strategies.base import CandidateSearch
from demcal.optimizer.strategies.dycors import Dycors
from demcal.optimizer.strategies.kriging_ei import KrigingEI


@pytest.fixture
def registry():
    """The registry as it was, restored after the test."""
    saved = dict(STRATEGIES)
    yield STRATEGIES
    STRATEGIES.clear()
    STRATEGIES.update(saved)


class Diagonal(Strategy):
    """Walks up the diagonal of the unit box and keeps what it was shown."""

    seen: list[History] = []

    def propose(self, history: History) -> np.ndarray:
        Diagonal.seen.append(history)
        return np.full(history.dimension, 0.01 * history.handed_out)


class Exploit(CandidateSearch):
    """The built-in candidate search with the lowest prediction chosen."""

    def choose(self, history, candidates, weight, polished):
        return candidates[int(np.argmin(history.surrogate.predict(candidates)))]


def test_built_in_strategies_are_registered_by_name():
    assert list(STRATEGIES) == [
        "dycors",
        "kriging_ei",
        "response_ei",
        "solution_map",
        "rackl_hanley",
    ]
    assert strategy_class("dycors") is Dycors and strategy_class("kriging_ei") is KrigingEI
    assert OptimizerSettings.from_dict({"strategy": "kriging_ei"}).surrogate_name == "kriging"


def test_unknown_strategy_lists_exactly_the_registered_names(registry):
    with pytest.raises(ValueError) as error:
        OptimizerSettings.from_dict({"strategy": "guess"})
    assert str(error.value) == f"optimizer.strategy: 'guess' is not one of {', '.join(registry)}"
    register_strategy("diagonal", Diagonal)
    with pytest.raises(
        ValueError,
        match="is not one of dycors, kriging_ei, response_ei, solution_map, rackl_hanley, "
        "diagonal$",
    ):
        OptimizerSettings.from_dict({"strategy": "guess"})
    with pytest.raises(ValueError, match="already registered"):
        register_strategy("diagonal", Diagonal)


def test_registered_surrogates_are_enforced(registry):
    register_strategy(
        "needs_kriging", Diagonal, surrogate="kriging", surrogates=("kriging", "smt_rbf")
    )
    assert OptimizerSettings.from_dict({"strategy": "needs_kriging"}).surrogate_name == "kriging"
    with pytest.raises(
        ValueError, match="cannot serve strategy needs_kriging; it needs kriging or smt_rbf"
    ):
        OptimizerSettings.from_dict({"strategy": "needs_kriging", "surrogate": "cubic_rbf"})


def test_a_registered_strategy_drives_the_optimizer(registry):
    register_strategy("diagonal", Diagonal)
    Diagonal.seen = []
    optimizer = Optimizer([0, 0], [1, 2], {"strategy": "diagonal", "max_evaluations": 12}, seed=1)
    proposals = []
    for k in range(12):
        (proposal,) = optimizer.ask()
        proposals.append(proposal)
        if k == 6:
            optimizer.tell(proposal.id, status="failed")
        else:
            optimizer.tell(proposal.id, replicates=[k, k + 2.0])
    adaptive = [p for p in proposals if not p.in_initial_design]
    assert len(adaptive) == len(Diagonal.seen) == 12 - optimizer.initial_size
    assert [p.x for p in adaptive] == [[0.01 * p.id, 0.02 * p.id] for p in adaptive]
    last = Diagonal.seen[-1]
    assert last.handed_out == last.evaluated == 11 and last.ids == tuple(range(11))
    assert (
        last.statuses[6] == "failed"
        and np.isnan(last.values[6])
        and last.select("failed").shape == (1, 2)
    )
    assert last.values[7] == 8.0 and last.variances[7] == pytest.approx(1.0)
    assert last.surrogate is not None and last.responses is None


def test_a_candidate_search_subclass_reuses_the_built_in_search(registry):
    register_strategy("exploit", Exploit)
    optimizer = Optimizer([0, 0], [1, 1], {"strategy": "exploit", "max_evaluations": 20}, seed=2)
    for _ in range(20):
        (proposal,) = optimizer.ask()
        optimizer.tell(proposal.id, float(np.sum((np.asarray(proposal.x) - 0.3) ** 2)))
    assert optimizer.best().value < 1e-3
