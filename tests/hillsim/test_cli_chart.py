"""``hillsim synth`` and ``hillsim extend`` from the command line, including bad options."""

import numpy as np
import pytest

from data_synthetic import FRANCIS_DIR
from tests.chart_files import assert_chart_matches
from hillsim.cli import main


def test_synth_writes_the_shipped_chart(tmp_path, capsys):
    assert main(["synth", str(tmp_path), "--seed", "0"]) == 0
    assert_chart_matches(tmp_path, FRANCIS_DIR)  # to the last written digit (tests/chart_files.py)
    assert "wrote" in capsys.readouterr().out


def test_extend_writes_table_and_plot(tmp_path, capsys):
    out, png = tmp_path / "ext.csv", tmp_path / "ext.png"
    assert main(["extend", str(FRANCIS_DIR), "--out", str(out), "--plot", str(png)]) == 0
    table = np.genfromtxt(out, delimiter=",", names=True, dtype=None, encoding="utf-8")
    assert set(table["origin"]) == {"measured", "runaway", "zero-opening", "zero-speed", "silent-region"}
    assert set(table["target"]) == {"q11", "m11"}
    assert png.stat().st_size > 10_000  # a real figure, not an empty canvas
    assert "K =" in capsys.readouterr().out


def test_extend_switches(tmp_path):
    out = tmp_path / "ext.csv"
    assert main(["extend", str(FRANCIS_DIR), "--out", str(out), "--no-zero-speed", "--no-runaway",
                 "--no-silent-regions"]) == 0
    origins = set(np.genfromtxt(out, delimiter=",", names=True, dtype=None, encoding="utf-8")["origin"])
    assert origins == {"measured", "zero-opening"}


@pytest.mark.parametrize(
    "extra,message",
    [
        (["--degree", "9"], "extrapolation_degree must be an integer in [1, 4], got 9"),
        (["--zero-opening-k", "-2"], "zero_opening_k must be a finite number > 0, got -2.0"),
    ],
)
def test_extend_bad_options_exit_2_with_message(tmp_path, capsys, extra, message):
    code = main(["extend", str(FRANCIS_DIR), "--out", str(tmp_path / "e.csv"), *extra])
    assert code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "e.csv").exists()  # nothing partial left behind


def test_extend_missing_folder(tmp_path, capsys):
    assert main(["extend", str(tmp_path / "none"), "--out", str(tmp_path / "e.csv")]) == 2
    assert "not a chart folder" in capsys.readouterr().err


def test_unknown_option_is_an_argparse_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["extend", str(FRANCIS_DIR), "--out", "x.csv", "--colour", "red"])
    assert exc.value.code == 2
    assert "--colour" in capsys.readouterr().err


@pytest.mark.external
def test_train_refuses_nets_whose_efficiency_exceeds_the_chart(tmp_path, capsys):
    """Sayano-Shushenskaya: its opening lines start at N11 = 56, so the paper's polynomial zero-speed extrapolation
    is poor and those nets reach eta 1.04 inside the digitized region: an error by default,
    nothing written; --allow-implausible writes them with a warning. The default (physical-model boundaries,
    weighted by cross-validation) trains this chart without error, and its one warning is that the fitted model gives
    no runaway speed beyond 8 of its lines (the chart has no runaway curve)."""
    from tests.external_charts import write_sayano_chart

    folder = write_sayano_chart(tmp_path / "sayano")
    poly = ["--boundaries", "polynomial", "--ensemble", "0", "--hidden", "5", "--boundary-weight", "1",
            "--regularization", "0", "--quiet"]
    assert main(["train", str(folder), "--out", str(tmp_path / "a.json")] + poly) == 2
    assert "the nets' efficiency reaches 1.0" in capsys.readouterr().err  # measured 1.041
    assert not (tmp_path / "a.json").exists()
    assert main(["train", str(folder), "--out", str(tmp_path / "a.json"), "--allow-implausible"] + poly) == 0
    assert "warning: the nets' efficiency reaches 1.0" in capsys.readouterr().out
    assert main(["train", str(folder), "--out", str(tmp_path / "b.json"), "--quiet"]) == 0
    out = capsys.readouterr().out
    warned = [line for line in out.splitlines() if "warning" in line]
    assert "efficiency reaches" not in out and len(warned) == 1 and warned[0].startswith("warning: toward runaway")


def test_train_synthetic_chart_gives_no_efficiency_warning(tmp_path, capsys):
    assert main(["train", str(FRANCIS_DIR), "--out", str(tmp_path / "n.json")]) == 0
    assert "efficiency reaches" not in capsys.readouterr().out
    # the digitized region travels inside nets.json: the hull of flow.csv's (N11, opening) points
    from hillchart.nets.hill_nets import load_nets
    from hillchart.io.samples import load_chart
    from simulate.loop.domain import convex_hull

    chart = load_chart(FRANCIS_DIR)
    hull = convex_hull(np.column_stack((chart.flow_n11, chart.flow_opening)))
    np.testing.assert_array_equal(load_nets(tmp_path / "n.json").digitized_region, hull)  # the same points


def test_chart_of_three_input_nets_says_where_they_are_read(tmp_path, capsys):
    from data_synthetic import PLANT_BULB

    out = tmp_path / "c.png"
    assert main(["chart", str(PLANT_BULB.parent / "bulb" / "nets.json"), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "flow.inputs must be" in err and "double-regulated unit's three-input nets" in err
    assert "hillsim report draws the unit's chart on its cam" in err and not out.exists()
    # two-input nets with other inputs: the plain message
    import json

    doc = json.loads((FRANCIS_DIR / "nets.json").read_text())
    doc["flow"]["inputs"] = ["n11", "stroke"]
    (tmp_path / "n.json").write_text(json.dumps(doc))
    assert main(["chart", str(tmp_path / "n.json"), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "flow.inputs must be" in err and "double-regulated" not in err
