"""demcal convergence: plan of variants, deviations from the reference, files (analytic engine)."""

import pandas as pd
import pytest
import yaml

from demcal.analysis.convergence import Variant, plan, summarise
from demcal.cli import main
from demcal.study.config import load_study
from demcal.study.model import freeze


def test_plan_holds_both_sweeps_through_the_configured_variant(analytic_config):
    study = load_study(analytic_config)
    variants, base = plan(
        study, "cylinder_lift", [0.5, 0.25, 0.125], [1000.0, 4000.0], study.centre_point()
    )
    assert base == Variant(0.25, 2000.0)
    assert set(variants) == {
        Variant(0.5, 2000.0),
        Variant(0.25, 2000.0),
        Variant(0.125, 2000.0),
        Variant(0.25, 1000.0),
        Variant(0.25, 4000.0),
    }


def test_each_sweep_is_compared_with_its_own_finest_run():
    """Time step and size effects stay apart: the base row is 0 % in neither sweep here."""
    runs = pd.DataFrame(
        [
            # fraction, size, seed, response
            (0.5, 2000.0, 0, 110.0),
            (0.5, 2000.0, 1, 112.0),
            (0.25, 2000.0, 0, 104.0),
            (0.25, 2000.0, 1, 106.0),
            (0.125, 2000.0, 0, 100.0),
            (0.125, 2000.0, 1, 100.0),
            (0.25, 4000.0, 0, 130.0),
            (0.25, 4000.0, 1, 130.0),
            (0.25, 1000.0, 0, 90.0),
            (0.25, 1000.0, 1, float("nan")),
        ],
        columns=["fraction", "size", "seed_index", "flow"],
    )
    runs["status"] = ["ok"] * 9 + ["failed"]
    runs["reason"] = [""] * 9 + ["unstable"]
    runs["cpu_s"], runs["wall_s"] = 1.0, 1.0
    table = summarise(runs, ["flow"], Variant(0.25, 2000.0))
    summary = table[table["runs_ok"] > 0].set_index(["fraction", "size"])
    assert summary.loc[(0.5, 2000.0), "flow_dt_deviation_pct"] == pytest.approx(11.0)
    assert summary.loc[(0.25, 2000.0), "flow_dt_deviation_pct"] == pytest.approx(5.0)
    assert summary.loc[(0.25, 2000.0), "flow_size_deviation_pct"] == pytest.approx(-100 * 25 / 130)
    assert summary.loc[(0.25, 1000.0), "flow_size_deviation_pct"] == pytest.approx(-100 * 40 / 130)
    assert (
        summary.loc[(0.125, 2000.0), "flow_size_deviation_pct"]
        != summary.loc[(0.125, 2000.0), "flow_size_deviation_pct"]
    )  # NaN: not in the size sweep
    assert summary.loc[(0.5, 2000.0), "flow_noise_pct"] == pytest.approx(100 * 2**0.5 / 111.0)
    assert table[table["runs_ok"] == 0]["failure"].tolist() == ["unstable"]


def test_plan_refuses_an_unsafe_fraction_and_a_bad_size(analytic_config):
    study = load_study(analytic_config)
    with pytest.raises(Exception, match="--fractions: 0.8 is above 0.5"):
        plan(study, "cylinder_lift", [0.8, 0.25], [2000.0], study.centre_point())
    with pytest.raises(
        Exception, match=r"--sizes \(particle_count\).particle_count: 5.0 is outside"
    ):
        plan(study, "cylinder_lift", [0.25], [5.0], study.centre_point())


def test_convergence_writes_table_and_plot(tmp_path, monkeypatch, analytic_config, capsys):
    monkeypatch.chdir(tmp_path)
    config = tmp_path / "study.yaml"
    config.write_text(yaml.safe_dump(analytic_config))
    code = main(
        [
            "convergence",
            str(config),
            "--fractions",
            "0.25",
            "0.125",
            "--sizes",
            "1000",
            "2000",
            "--seeds",
            "2",
            "--workers",
            "1",
        ]
    )
    assert code == 0
    out = tmp_path / "results" / analytic_config["study"] / "convergence"
    summary = pd.read_csv(out / "cylinder_lift_summary.csv")
    assert len(summary) == 3 and summary["runs_ok"].tolist() == [2, 2, 2]
    # the analytic engine ignores the resolution and this config has no noise:
    # every variant matches the finest run of its sweep exactly
    assert summary["bulk_density_dt_deviation_pct"].abs().max() == pytest.approx(0.0, abs=1e-9)
    assert summary["bulk_density_size_deviation_pct"].abs().max() == pytest.approx(0.0, abs=1e-9)
    assert (out / "cylinder_lift.png").stat().st_size > 0
    assert len(pd.read_csv(out / "cylinder_lift.csv")) == 6
    out = capsys.readouterr().out
    assert "configured dt0.25_size2000" in out
    assert "6 simulations, 1 at a time; how long they take is not known yet" in out
    table = out[out.index("bulk_density: seed mean") : out.index("demcal convergence: table")]
    assert max(len(line) for line in table.splitlines()) <= 100


def test_convergence_takes_a_study_by_its_name_once_it_has_run(
    tmp_path, monkeypatch, analytic_config, capsys
):
    """The frozen results/<study>/study.json stands for the study; a name not run is named."""
    monkeypatch.chdir(tmp_path)
    freeze(load_study(analytic_config))
    args = ["--fractions", "0.25", "--sizes", "2000", "--seeds", "1", "--jobs", "1"]
    assert main(["convergence", "unit", *args]) == 0  # --jobs: the former name of --workers
    assert "1 simulation, 1 at a time" in capsys.readouterr().out
    assert (tmp_path / "results/unit/convergence/cylinder_lift_summary.csv").is_file()
    assert main(["convergence", "nonesuch", *args]) == 2
    assert "'nonesuch': no such study file, and no study of that name in results/" in (
        capsys.readouterr().err
    )


def test_convergence_unknown_scene_is_one_clear_error(
    tmp_path, monkeypatch, analytic_config, capsys
):
    monkeypatch.chdir(tmp_path)
    config = tmp_path / "study.yaml"
    config.write_text(yaml.safe_dump(analytic_config))
    assert main(["convergence", str(config), "--scene", "shear_box"]) == 2
    assert "--scene shear_box: not a scene of the study (cylinder_lift)" in capsys.readouterr().err


def test_particle_count_varies_at_constant_volume_of_material(analytic_config):
    from demcal.analysis.convergence import variant_settings

    study = load_study(analytic_config)
    coarse = variant_settings(
        study, "cylinder_lift", Variant(0.25, 1000.0), "f", study.centre_point()
    )
    assert coarse["particle_count"] == 1000
    assert coarse["d50"] == pytest.approx(2.0e-3 * 2.0 ** (1.0 / 3.0))
    assert coarse["particle_count"] * coarse["d50"] ** 3 == pytest.approx(2000 * 2.0e-3**3)
