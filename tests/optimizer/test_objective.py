"""The objective's forms: the code's list and the study file's schema name the same ones."""

from __future__ import annotations

import pytest

from demcal.optimizer.objective import OBJECTIVE_FORMS, ResponseObjective, Target
from demcal.study.schema import load_schema


def test_the_schema_offers_the_objective_forms_the_code_computes():
    assert load_schema()["properties"]["objective"]["enum"] == ["auto", *OBJECTIVE_FORMS]


def test_an_unknown_form_is_refused_before_any_value_is_computed():
    with pytest.raises(ValueError, match="'squared' is not one of"):
        ResponseObjective((Target("s", "a", 1.0),), "squared")
