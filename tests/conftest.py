"""The tests' shared fixtures; the shared helpers are in helpers.py."""

from __future__ import annotations

import copy

import pytest
from helpers import ANALYTIC_STUDY


@pytest.fixture
def analytic_config():
    """A fresh copy of a valid analytic-engine study config."""
    return copy.deepcopy(ANALYTIC_STUDY)
