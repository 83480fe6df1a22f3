"""Does a cheaper level pay? The figures of ``demcal fidelity check`` (issue 38, item 2) on
runs whose link to the fine level is known, the analytic engine's levels (item 8), and the
command itself."""

from __future__ import annotations

import copy
import math

import numpy as np
import pandas as pd
import pytest
import yaml
from helpers import ANALYTIC_STUDY, demcal, finish

from demcal.analysis.fidelity import compare, pooled_noise
from demcal.engines.analytic import distorted, ripple_phase
from demcal.optimizer.levels import correlation_lower_bound, variance_ratio
from demcal.results.records import FINE

SCENE = "cylinder_lift"
RESPONSE = f"{SCENE}.angle_of_repose"


def runs(link, points=10, replicates=2, noise=0.0, cpu=(60.0, 6.0), seed=1) -> pd.DataFrame:
    """A check's runs table: the coarse response is x, the fine one link(x), each run with
    Gaussian noise of sd ``noise``; cpu (fine, coarse) seconds per simulation."""
    rng = np.random.default_rng(seed)
    rows = []
    for k, x in enumerate(np.linspace(10.0, 40.0, points)):
        for level, value, seconds in ((FINE, link(x, k), cpu[0]), ("coarse", x, cpu[1])):
            for r in range(replicates):
                rows.append(
                    {
                        "evaluation": f"{level}{k}",
                        "level": level,
                        "point": (float(k),),
                        "scene": SCENE,
                        "replicate": r,
                        "response": RESPONSE,
                        "value": value + noise * rng.standard_normal(),
                        "cpu_s": seconds,
                    }
                )
    return pd.DataFrame(rows)


def test_variance_ratio_is_the_two_model_multifidelity_estimators():
    assert variance_ratio(1.0, 0.0) == 0.0
    assert variance_ratio(0.0, 0.1) == 1.0 and variance_ratio(-0.5, 0.1) == 1.0
    assert variance_ratio(0.9, 0.1) == pytest.approx((math.sqrt(0.19) + math.sqrt(0.081)) ** 2)
    assert variance_ratio(0.9, 1.0) > 1.0  # as dear as fine: never pays
    assert math.isnan(variance_ratio(math.nan, 0.1))


def test_the_correlation_bound_is_below_r_and_tightens_with_points():
    bounds = [correlation_lower_bound(0.9, n) for n in (5, 10, 40)]
    assert bounds[0] < bounds[1] < bounds[2] < 0.9
    assert math.isnan(correlation_lower_bound(0.9, 3))


def test_a_scaled_and_shifted_level_is_found_and_pays():
    found = compare(runs(lambda x, k: 2.0 * x + 5.0, noise=0.01), "coarse", RESPONSE)
    assert found.scale == pytest.approx(2.0, rel=1e-3) and found.bias == pytest.approx(5.0, abs=0.1)
    assert found.correlation > 0.999 and found.points == 10
    assert found.cost_ratio == pytest.approx(0.1)
    assert found.pays and found.verdict.startswith("pays: saves")
    assert found.noise_fine == pytest.approx(0.01, rel=0.6)


def test_an_uncorrelated_or_dear_level_does_not_pay():
    rough = compare(runs(lambda x, k: 25.0 + 10.0 * math.sin(3.0 * k)), "coarse", RESPONSE)
    assert abs(rough.correlation) < 0.6 and not rough.pays
    assert rough.verdict.startswith("does not pay")
    dear = compare(runs(lambda x, k: x, noise=0.5, cpu=(60.0, 50.0)), "coarse", RESPONSE)
    assert dear.correlation > 0.99 and not dear.pays
    few = compare(runs(lambda x, k: x, points=3), "coarse", RESPONSE)
    assert few.verdict.startswith("unknown: 3 points ran at both levels")


def test_pooled_noise_needs_a_point_run_twice():
    def fine(table: pd.DataFrame) -> pd.DataFrame:
        return table[table["level"] == FINE]

    assert math.isnan(pooled_noise(fine(runs(lambda x, k: x, replicates=1))))
    noisy = fine(runs(lambda x, k: x, replicates=4, noise=2.0))
    assert pooled_noise(noisy) == pytest.approx(2.0, rel=0.3)


def test_the_analytic_levels_distort_the_model_as_documented():
    exact = {"angle_of_repose": 30.0, "bulk_density": 1500.0}
    parameters = {"sliding_friction_pp": 0.4, "rolling_friction_pp": 0.1}
    assert distorted(exact, parameters, {}) == exact
    level = {"scale": 0.9, "bias": {"angle_of_repose": 3.0}, "ripple": {"bulk_density": 0.1}}
    got = distorted(exact, parameters, level)
    assert got["angle_of_repose"] == pytest.approx(0.9 * 30.0 + 3.0)
    wave = 0.1 * 1500.0 * math.sin(ripple_phase(parameters))
    assert got["bulk_density"] == pytest.approx(0.9 * 1500.0 + wave)
    moved = ripple_phase({**parameters, "sliding_friction_pp": 0.5})
    assert moved != ripple_phase(parameters)


@pytest.mark.slow
def test_demcal_fidelity_check_measures_the_analytic_levels(tmp_path):
    """Through the command: a level scaled by 0.8 is measured as fine = 1.25 coarse and pays at
    a tenth of the CPU; a level with a large ripple does not pay for the angle."""
    config = {
        **copy.deepcopy(ANALYTIC_STUDY),
        "study": "levels",
        "engine": {"name": "analytic", "noise": 0.002, "cpu": 60.0},
        "fidelities": {
            "coarse": {"engine": {"cpu": 6.0, "scale": 0.8}},
            "poor": {"engine": {"cpu": 6.0, "ripple": 0.4}},
        },
    }
    (tmp_path / "levels.yaml").write_text(yaml.safe_dump(config))
    out = finish(demcal(tmp_path, "fidelity", "check", "levels.yaml", "--points", "6"))
    assert "6 Sobol points at fine, coarse, poor, 2 seeds each" in out
    table = pd.read_csv(tmp_path / "results" / "levels-fidelity" / "fidelity.csv")
    coarse = table[(table["level"] == "coarse") & (table["response"] == RESPONSE)].iloc[0]
    assert coarse["scale"] == pytest.approx(1.25, rel=0.02) and coarse["pays"]
    assert coarse["cost_ratio"] == pytest.approx(0.1)
    poor = table[(table["level"] == "poor") & (table["response"] == RESPONSE)].iloc[0]
    assert not poor["pays"]
    assert (tmp_path / "results" / "levels-fidelity" / "fidelity.png").stat().st_size > 10_000
    refused = demcal(tmp_path, "fidelity", "check", "levels.yaml", "--levels", "nope")
    _, err = refused.communicate(timeout=60)
    assert refused.returncode == 2
    assert err.strip() == "demcal: --levels nope: not a cheaper level of the study (coarse, poor)"
