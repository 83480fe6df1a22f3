"""`demcal psd fit`: GGS, RRSB and LOGN (Richter & Will 2021, eqs. 1-3) fitted to sieve data."""

from pathlib import Path

import numpy as np
import pytest

from demcal.cli import main
from demcal.physics.psd import sample_diameters, sampled_q3
from demcal.physics.sieve import fit_all, ggs, logn, number_median, rrsb

SHIPPED = Path(__file__).resolve().parents[2] / "config/examples/sieve_gravel_8_16.csv"
SIEVES = np.array([4.0, 5.6, 6.3, 8.0, 10.0, 11.2, 12.5, 14.0, 16.0, 20.0, 22.4])


@pytest.mark.parametrize(
    ("cdf", "name", "size", "shape"),
    [(ggs, "GGS", 17.0, 3.0), (rrsb, "RRSB", 12.0, 4.0), (logn, "LOGN", 11.16, 0.26)],
)
def test_each_function_recovers_its_own_noise_free_curve_and_ranks_first(cdf, name, size, shape):
    fits = fit_all(SIEVES, cdf(SIEVES, size, shape))
    best = fits[0]
    assert (best.function, best.size, best.shape) == (
        name,
        pytest.approx(size, rel=1e-6),
        pytest.approx(shape, rel=1e-6),
    )
    assert best.r2 == pytest.approx(1.0, abs=1e-9) and best.mse < 1e-12
    assert [f.mse for f in fits] == sorted(f.mse for f in fits)
    assert all(f.r2 < 0.999 for f in fits[1:])


def test_number_median_matches_the_mass_median_of_spheres_sampled_by_number():
    """demcal samples by number; the mass median of those spheres is the LOGN fit's d50."""
    d = sample_diameters(400_000, number_median(11.16, 0.26), 0.26, 8.0, np.random.default_rng(1))
    mass = np.cumsum(np.sort(d) ** 3)
    assert np.sort(d)[np.searchsorted(mass, mass[-1] / 2)] == pytest.approx(11.16, rel=2e-3)


@pytest.mark.parametrize("truncation", [1.5, 3.0])
def test_sampled_q3_is_the_mass_share_of_the_spheres_the_scenes_draw(truncation):
    d50, sigma = number_median(11.16, 0.26), 0.26
    spheres = sample_diameters(200_000, d50, sigma, truncation, np.random.default_rng(2))
    drawn = [(spheres[spheres < d] ** 3).sum() / (spheres**3).sum() for d in SIEVES]
    assert sampled_q3(SIEVES, d50, sigma, truncation) == pytest.approx(drawn, abs=3e-3)


def test_sampled_q3_without_a_cut_is_the_lognormal_of_the_mass_median():
    q = sampled_q3(SIEVES, number_median(11.16, 0.26), 0.26, 40.0)
    assert q == pytest.approx(logn(SIEVES, 11.16, 0.26), abs=1e-12)


def write(tmp_path, text):
    path = tmp_path / "sieve.csv"
    path.write_text(text)
    return path


def test_cli_prints_the_ranked_fits_and_the_scene_settings(tmp_path, capsys):
    q = 100 * logn(SIEVES, 11.16, 0.26)
    rows = "".join(f"{d},{p:.6f}\n" for d, p in zip(SIEVES[::-1], q[::-1]))  # largest first
    assert main(["psd", "fit", str(write(tmp_path, "# lab sheet\nd_mm,Q3_percent\n" + rows))]) == 0
    out = capsys.readouterr().out
    ranks = [line.split()[1] for line in out.splitlines() if line[:1].isdigit()]
    assert ranks == ["LOGN", "RRSB", "GGS"]
    assert "d50 = 11.16 mm, sigma_ln = 0.26 " in out
    assert f"d50: {number_median(11.16, 0.26) / 1000:.4g}   # m\nsigma_ln: 0.26\n" in out
    cuts = out.split("fits the sieves\n# with R² ")[1].split(", R² ")
    assert [cut.split(" at ")[1].split(" (")[0] for cut in cuts] == ["1.5", "2", "3"]
    assert float(cuts[0].split()[0]) < float(cuts[1].split()[0]) < float(cuts[2].split()[0])


def test_the_shipped_sieve_file_is_fitted_best_by_the_lognormal(capsys):
    assert main(["psd", "fit", str(SHIPPED)]) == 0
    ranks = [line.split()[1] for line in capsys.readouterr().out.splitlines() if line[:1] == "1"]
    assert ranks == ["LOGN"]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("d_mm,Q3_percent\n4,0\n8,30\n11.2,20\n16,95\n", "line 4, column Q3_percent: 20 % passes"),
        ("d_mm,Q3_percent\n4,0\n8,30\n11.2,50\n16,101\n", "line 5, column Q3_percent: 101 %"),
        ("d_mm,Q3_percent\n4,0\n8,-3\n11.2,50\n", "line 3, column Q3_percent: -3 %"),
        ("d_mm,Q3_percent\n0,0\n8,30\n11.2,50\n", "line 2, column d_mm: 0 mm must be > 0"),
        ("d_mm,Q3_percent\n4,0\n8,30\n", "2 sieves; a fit needs at least 3"),
        ("d_mm,passing\n4,0\n8,30\n11.2,50\n", "line 1: no column 'Q3_percent'"),
        ("d_mm,Q3_percent\n4,0\n8,abc\n11.2,50\n", "line 3, column Q3_percent: 'abc' is not a"),
        ("d_mm,Q3_percent\n4,0\nnan,30\n11.2,50\n", "line 3, column d_mm: nan is not a finite"),
        ("d_mm,Q3_percent\n4,0\n8\n11.2,50\n", "line 3, column Q3_percent: missing"),
        ("d_mm,Q3_percent\n4,0\n8,30\n8,50\n", "line 4, column d_mm: 8 mm twice (line 3)"),
        ("d_mm,Q3_percent\n4,0\n8,0.3\n11.2,0.5\n16,1\n", "every value is <= 1: give %"),
        ("d_mm,Q3_percent\n4,0\n8,0\n11.2,50\n16,100\n", "at least two sieves that pass"),
        ("# only a comment\n", "empty; expected a header line with the columns d_mm"),
    ],
)
def test_bad_sieve_files_are_one_line_naming_file_line_and_column(tmp_path, capsys, text, message):
    path = write(tmp_path, text)
    assert main(["psd", "fit", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"demcal: {path}") and message in err
    assert len(err.strip().splitlines()) == 1


def test_help_names_the_columns_and_their_units(capsys):
    with pytest.raises(SystemExit) as done:
        main(["psd", "fit", "--help"])
    assert done.value.code == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "d_mm (sieve aperture, mm) and Q3_percent (cumulative mass passing, %)" in out


def test_a_missing_sieve_file_is_one_line(tmp_path, capsys):
    assert main(["psd", "fit", str(tmp_path / "none.csv")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"demcal: cannot read the sieve file {tmp_path / 'none.csv'}")
    assert len(err.strip().splitlines()) == 1


def test_other_columns_are_ignored(tmp_path, capsys):
    q = 100 * rrsb(SIEVES, 12.0, 4.0)
    rows = "".join(f"x,{d},{p:.8f}\n" for d, p in zip(SIEVES, q))
    assert main(["psd", "fit", str(write(tmp_path, "sample,d_mm,Q3_percent\n" + rows))]) == 0
    assert "1    RRSB      d63 = 12 mm, n = 4 " in capsys.readouterr().out


def test_a_file_with_a_byte_order_mark_is_fitted(tmp_path, capsys):
    """Excel's "CSV UTF-8" starts the file with a byte-order mark: not part of the header."""
    q = 100 * logn(SIEVES, 11.16, 0.26)
    rows = "".join(f"{d},{p:.6f}\n" for d, p in zip(SIEVES, q))
    path = tmp_path / "excel.csv"
    path.write_text("d_mm,Q3_percent\n" + rows, encoding="utf-8-sig")
    assert path.read_bytes().startswith(b"\xef\xbb\xbf")
    assert main(["psd", "fit", str(path)]) == 0
    assert "d50 = 11.16 mm, sigma_ln = 0.26 " in capsys.readouterr().out


def test_a_folder_is_refused_as_not_a_file(tmp_path, capsys):
    assert main(["psd", "fit", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err == (
        f"demcal: {tmp_path}: not a regular file (a folder, device or pipe); give the sieve "
        "analysis as a CSV file\n"
    )
