"""``hillsim linearize`` from the command line: JSON output, maps, bad options."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hillchart.linearize import six_coefficients
from hillchart.synthetic.francis import SyntheticFrancis
from hillsim.cli import main


def test_linearize_synthetic_prints_the_exact_coefficients(capsys):
    assert main(["linearize", "synthetic", "--n11", "67.8", "--opening", "23.46"]) == 0
    out = json.loads(capsys.readouterr().out)
    exact = six_coefficients(SyntheticFrancis(), n11=67.8, opening=23.46)
    assert out["coefficients"] == {k: getattr(exact, k) for k in ("ex", "ey", "eh", "eqx", "eqy", "eqh")}
    assert out["e"] == pytest.approx(exact.eqy * exact.eh / exact.ey - exact.eqh, rel=1e-15)
    assert out["operating_point"]["q11_m3_s"] == pytest.approx(0.53, abs=2e-3)  # the HLA339-like rated Q11


def test_linearize_from_plant_units_and_map(tmp_path, capsys):
    png = tmp_path / "maps.png"
    # HLA339: n = 200 r/min, H = 176 m, D1 = 4.5 m -> N11 = 67.84 r/min
    assert main(["linearize", "synthetic", "--speed-rpm", "200", "--head-m", "176", "--d1-m", "4.5",
                 "--opening", "23.46", "--map", str(png), "--grid", "25"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["operating_point"]["n11_rpm"] == pytest.approx(200 * 4.5 / np.sqrt(176), rel=1e-14)
    assert out["map"] == str(png) and png.stat().st_size > 20_000


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--n11", "67.8", "--opening", "0"], "opening must be > 0"),
        (["--opening", "20"], "needs --n11, or all of --speed-rpm"),
        (["--n11", "67.8", "--opening", "20", "--head-m", "100"], "either --n11 or"),
        (["--speed-rpm", "200", "--head-m", "-1", "--d1-m", "4.5", "--opening", "20"], "head_m must be"),
        (["--n11", "67.8", "--opening", "20", "--map", "x.png", "--grid", "1"], "--grid must be in [2, 1000]"),
        (["--n11", "67.8", "--opening", "20", "--map", "x.png", "--n11-range", "80", "60"],
         "--n11-range must satisfy 0 < LO < HI"),
    ],
)
def test_linearize_bad_options(argv, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["linearize", "synthetic", *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("hillsim linearize: error:") and message in err


def test_linearize_missing_nets_file(capsys, tmp_path):
    pytest.importorskip("hillchart.nets.hill_nets")
    assert main(["linearize", str(tmp_path / "none.json"), "--n11", "67.8", "--opening", "20"]) == 2
    err = capsys.readouterr().err
    # the one resolver of characteristics (simulate.components.turbine.kinds.resolve_characteristics) names the argument
    assert err.startswith("hillsim linearize: error: NETS = ") and "none.json' does not exist" in err
    assert "relative to the plant file" not in err  # NETS is relative to the working folder


def test_linearize_ideal_turbine_needs_a_plant_and_is_exact_with_one(capsys):
    """NETS goes through the plant file's resolver: 'ideal' is the ideal turbine of the plant's rated values."""
    from data_synthetic import PLANT_HLA339

    assert main(["linearize", "ideal", "--n11", "67.8", "--opening", "20"]) == 2
    assert "NETS = 'ideal' needs the plant's rated values" in capsys.readouterr().err
    assert main(["linearize", "ideal", "--plant", str(PLANT_HLA339), "--stroke", "0.68"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["source"].startswith("ideal turbine")
    # the ideal turbine's coefficients are exactly (-1, 1, 1.5, 0, 1, 0.5) (docs/identification.md, six
    # coefficients); 1e-9 leaves room for the rounding of the analytic derivatives at the plant's operating point
    got = [out["coefficients"][k] for k in ("ex", "ey", "eh", "eqx", "eqy", "eqh")]
    np.testing.assert_allclose(got, [-1.0, 1.0, 1.5, 0.0, 1.0, 0.5], atol=1e-9)


def test_linearize_shipped_nets_json(capsys, tmp_path):
    from hillchart.nets.hill_nets import load_nets

    from data_synthetic import FRANCIS_DIR

    path = FRANCIS_DIR / "nets.json"
    png = tmp_path / "nets_maps.png"
    assert main(["linearize", str(path), "--n11", "67.8", "--opening", "23.46", "--map", str(png),
                 "--grid", "30"]) == 0
    out = json.loads(capsys.readouterr().out)
    ref = six_coefficients(load_nets(path), n11=67.8, opening=23.46)
    assert out["coefficients"] == {k: getattr(ref, k) for k in ("ex", "ey", "eh", "eqx", "eqy", "eqh")}
    assert out["opening_unit"] == "mm" and png.stat().st_size > 20_000


def test_linearize_malformed_nets_json(capsys, tmp_path):
    bad = tmp_path / "nets.json"
    bad.write_text('{"format": "something else"}')
    assert main(["linearize", str(bad), "--n11", "67.8", "--opening", "20"]) == 2
    err = capsys.readouterr().err
    assert "hillsim linearize: error:" in err and "nets.json" in err
