"""The saved state: optimizer.json files written before the optimizer was split into modules."""

import json
from pathlib import Path

import numpy as np
import pytest

from demcal.optimizer import Optimizer
from demcal.optimizer.objective import ResponseObjective
from demcal.optimizer.settings import OptimizerSettings

DATA = Path(__file__).parent / "data"

#: The next proposals (real units) of the code that wrote each file, before the split.
NEXT = {
    "dycors": [
        [0.3375338014600896, 0.24787244151699875],
        [0.32413929057408264, 0.21708551892153702],
    ],
    "response_ei_rbf": [
        [0.4112225546491818, 0.08939486697870042],
        [0.32038770808619266, 0.19070340117929233],
    ],
    "rackl_hanley": [[0.3922372662365762, 0.11954322746177108]],
}


@pytest.mark.parametrize("name", sorted(NEXT))
def test_an_old_state_loads_saves_the_same_and_resumes_to_the_same_proposals(name):
    text = (DATA / f"optimizer_v1_{name}.json").read_text()
    optimizer = Optimizer.from_json(text)
    old, saved = json.loads(text), json.loads(optimizer.to_json())
    if "objective" in old:  # the copy of the targets becomes the name of their version
        assert saved.pop("objective_version") == (
            ResponseObjective.from_dict(old.pop("objective")).version
        )
    defaults = OptimizerSettings().to_dict()
    for added in set(saved["settings"]) - set(old["settings"]):  # settings added since: defaults
        assert saved["settings"].pop(added) == defaults[added]
    termination, old_termination = (
        state["settings"]["early_termination"] for state in (saved, old)
    )
    for added in set(termination) - set(old_termination):
        assert termination.pop(added) == defaults["early_termination"][added]
    assert saved == old
    # the same to rounding: the last digits vary with the machine's BLAS
    np.testing.assert_allclose([proposal.x for proposal in optimizer.ask(2)], NEXT[name], rtol=1e-7)


def test_a_state_that_scored_responses_needs_its_objective():
    text = (DATA / "optimizer_v1_response_ei_rbf.json").read_text()
    objective = Optimizer.from_json(text).objective
    saved = Optimizer.from_json(text).to_json()
    with pytest.raises(ValueError, match=f"objective {objective.version}; give from_json"):
        Optimizer.from_json(saved)
    assert Optimizer.from_json(saved, objective).ask(2)[0].x == NEXT["response_ei_rbf"][0]


def test_another_state_version_is_refused():
    text = (DATA / "optimizer_v1_dycors.json").read_text().replace('"version": 1', '"version": 2')
    with pytest.raises(ValueError, match="optimizer state version 2 is not 1"):
        Optimizer.from_json(text)
