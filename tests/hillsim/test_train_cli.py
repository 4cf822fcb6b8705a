"""``hillsim train`` options: bounded options, selection reported, nothing written on
any error, progress on stderr."""

import json

import pytest

from data_synthetic import FRANCIS_DIR
from hillsim.cli import main


@pytest.mark.parametrize("argv,message", [
    (["--hidden", "0"], "--hidden must be an integer in [1, 30], got '0'"),
    (["--hidden", "10000"], "--hidden must be an integer in [1, 30], got '10000'"),
    (["--hidden", "five"], "--hidden must be an integer in [1, 30] or 'auto', got 'five'"),
    (["--boundary-weight", "0"], "--boundary-weight must be a number in (0.0, 1.0] or 'auto', got '0'"),
    (["--boundary-weight", "nan"], "--boundary-weight must be a number in (0.0, 1.0]"),
    (["--regularization", "-1"], "--regularization must be a number in [0.0, 1.0] or 'auto', got '-1'"),
    (["--ensemble", "1000"], "--ensemble must be an integer in [0, 100], got 1000"),
    (["--restarts", "0"], "--restarts must be an integer in [1, 1000], got 0"),
    (["--seed", "-1"], "--seed must be an integer in [0, 2147483647], got -1"),
    (["--stops", "matlab"], "--stops must be one of auto, paper, longer, got 'matlab'"),
    (["--boundaries", "spline"], None),
])
def test_bad_options_exit_2_and_write_nothing(tmp_path, capsys, argv, message):
    out = tmp_path / "n.json"
    if message is None:  # argparse choices
        with pytest.raises(SystemExit):
            main(["train", str(FRANCIS_DIR), "--out", str(out)] + argv)
    else:
        assert main(["train", str(FRANCIS_DIR), "--out", str(out)] + argv) == 2
        assert message in capsys.readouterr().err
    assert not out.exists()


def test_output_path_is_checked_before_training(tmp_path, capsys):
    assert main(["train", str(FRANCIS_DIR), "--out", str(tmp_path / "missing" / "n.json")]) == 2
    err = capsys.readouterr().err
    assert "folder" in err and "does not exist" in err
    assert main(["train", str(FRANCIS_DIR), "--out", str(tmp_path)]) == 2
    assert "is a folder" in capsys.readouterr().err


def test_extend_checks_plot_path_before_writing_the_table(tmp_path, capsys):
    out = tmp_path / "ext.csv"
    assert main(["extend", str(FRANCIS_DIR), "--out", str(out), "--plot", str(tmp_path / "nope" / "p.png")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert not out.exists()


def test_paper_net_with_fixed_hyperparameters_reports_them(tmp_path, capsys):
    out = tmp_path / "n.json"
    assert main(["train", str(FRANCIS_DIR), "--out", str(out), "--hidden", "5", "--ensemble", "0",
                 "--boundary-weight", "1", "--regularization", "0"]) == 0
    captured = capsys.readouterr()
    doc = json.loads(out.read_text())
    assert doc["flow"]["W1"] and len(doc["flow"]["W1"]) == 5 and "ensemble" not in doc  # the paper's 2-5-1 net
    sel = doc["training"]["flow"]["selection"]
    assert (sel["hidden"], sel["boundary_weight"], sel["regularization"]) == (5, 1.0, 0.0)
    # the stops are still chosen (no option fixes them): the paper's and the longer fit, scored by the CV
    assert [(c["goal"], c["max_fail"]) for c in sel["candidates"]] == [(1e-5, 6), (1e-7, 100)]
    assert (sel["goal"], sel["max_fail"]) in ((1e-5, 6), (1e-7, 100))
    assert "flow     5    1.0     0.0" in captured.out
    assert "final fit 2-5-1" in captured.err  # progress goes to stderr


def test_default_selection_is_recorded_in_nets_json():
    """The shipped file was trained with the defaults: what the selection chose and why is in "training"."""
    doc = json.loads((FRANCIS_DIR / "nets.json").read_text())
    for key in ("flow", "torque"):
        sel = doc["training"][key]["selection"]
        assert 5 <= sel["hidden"] <= 10 and sel["boundary_weight"] in (0.03, 0.1, 0.3, 1.0)
        assert sel["regularization"] in (0.0, 1e-5, 1e-4) and "CV" in sel["rule"]
        # 4 boundary weights + 2 stops + 4 hidden sizes + 3 regularizations, each scored by 5-fold CV
        assert len(sel["candidates"]) == 13 and (sel["goal"], sel["max_fail"]) in ((1e-5, 6), (1e-7, 100))
        assert sel["cv_mse_best"] == min(c["cv_mse"] for c in sel["candidates"])
        # the point net starts at the members' size and grows only while it cannot follow their median
        distilled = doc["training"][key]["distillation"]
        assert distilled["tried"][0]["hidden"] == sel["hidden"] and len(doc[key]["W1"]) == distilled["hidden"]
    assert len(doc["ensemble"]) == 10 and doc["training"]["extension"]["boundaries"] == "model"


def test_train_states_the_physical_models_throat_foot(tmp_path, capsys):
    """The shipped chart's turbine has no foot (p = 0.014 against the kept level 0.01); a chart drawn from a turbine
    with a rational foot of 1.8 mm gets one (1.82 mm measured): ``hillsim train`` says which, and nets.json records
    it (``training.extension.throat_foot``, chart opening units, and its p-value)."""
    from hillchart.synthetic.francis import FAMILY, DigitizationOptions, write_synthetic_chart
    from hillchart.synthetic.francis_variants import OutOfClassMember, VariantPhysics

    base = FAMILY["medium"]
    member = OutOfClassMember(base.params, base.layout, "medium with a foot",
                              VariantPhysics(throat_foot_mm=1.8, throat_law="rational"))
    chart = tmp_path / "footed"
    write_synthetic_chart(chart, seed=0, turbine=member,
                          options=DigitizationOptions(points_per_line=6, spacing="uneven", noise_pct=0.15))
    for folder, says in ((FRANCIS_DIR, "no throat foot (F-test p = 0.0141, kept below 0.01); the form with the foot is "
                                        "0.64 likely and weighed below the lowest line"),
                         (chart, "throat foot a_0 = 1.8")):
        out = tmp_path / f"{folder.name}.json"
        assert main(["train", str(folder), "--out", str(out), "--ensemble", "0"]) == 0
        printed = [line for line in capsys.readouterr().out.splitlines() if line.startswith("physical turbine model")]
        assert len(printed) == 1 and says in printed[0], printed
        extension = json.loads(out.read_text())["training"]["extension"]
        assert set(extension) >= {"model_misfit_pct", "throat_foot", "throat_foot_p_value"}
        assert (1.5 < extension["throat_foot"] < 2.1) == (folder == chart)
        # the form not chosen: a foot on the shipped chart (0.64 likely), none beside the 1.8 mm foot (< 1e-6)
        other = extension["other_form"]
        assert (other["throat_foot"] > 0, other["probability"] > 0.5) == ((True, True) if folder == FRANCIS_DIR
                                                                          else (False, False))


@pytest.mark.external
def test_train_warns_where_the_model_gives_no_runaway_beyond_the_lines(tmp_path, capsys):
    """The real Sayano chart has no runaway curve, and the model fitted to it ends (N11 = 104.9) before the runaway
    speed of its 8 largest openings: ``hillsim train`` prints what is missing there and how to fix it, after its
    table, and nets.json records it; the shipped chart (with its runaway curve) trains without that warning."""
    from tests.external_charts import write_sayano_chart

    chart = write_sayano_chart(tmp_path / "sayano")
    for folder, warned in ((chart, True), (FRANCIS_DIR, False)):
        out = tmp_path / f"{folder.name}.json"
        assert main(["train", str(folder), "--out", str(out), "--ensemble", "0"]) == 0
        printed = [line for line in capsys.readouterr().out.splitlines()
                   if line.startswith("warning: toward runaway")]
        training = json.loads(out.read_text())["training"]
        recorded = training.get("warnings", [])
        assert len(printed) == len(recorded) == int(warned), printed
        if warned:
            assert "8 of the 12 opening lines" in printed[0] and "give the runaway curve (runaway.csv" in printed[0]
            assert printed[0] == f"warning: {recorded[0]}"
            assert training["lines_without_runaway"] == [26.0, 30.0, 34.0, 38.0, 42.0, 46.0, 54.0, 58.0]
        else:
            assert "lines_without_runaway" not in training


def test_stops_given_are_the_fit_s_and_recorded(tmp_path):
    """``--stops paper`` fixes the Levenberg-Marquardt stops at the paper's (HillNet's defaults: the same numbers)
    and ``--stops longer`` at the selection's other candidate; nets.json records them per net, as it records the
    cross-validation's choice without the option."""
    from hillchart.nets.estimator import HillNet
    from hillchart.nets.training import LONGER_STOPS, PAPER_STOPS

    assert PAPER_STOPS == {"goal": HillNet().goal, "max_fail": HillNet().max_fail}
    for stops, want in (("paper", PAPER_STOPS), ("longer", LONGER_STOPS)):
        out = tmp_path / f"{stops}.json"
        assert main(["train", str(FRANCIS_DIR), "--out", str(out), "--ensemble", "0", "--hidden", "5", "--stops",
                     stops, "--quiet"]) == 0
        training = json.loads(out.read_text())["training"]
        for key in ("flow", "torque"):
            selection = training[key]["selection"]
            assert {"goal": selection["goal"], "max_fail": selection["max_fail"]} == want, (stops, key)


def test_a_chart_of_three_lines_trains_with_the_wide_no_evidence_band(tmp_path, capsys):
    """Three opening lines leave no held-out fold: ``train`` says so and writes the no-evidence band (growing as d^2
    only up to :data:`hillchart.extension.band.NO_EVIDENCE_CAP`, kappa 12.3). Its kappa was once refused by the
    silent model's bound of 10 on kappa itself, so such a chart could not be trained; the bound is now on the band at
    the shut vanes, which is 1.2."""
    import shutil

    from hillchart.extension.band import NO_EVIDENCE_CAP, NO_EVIDENCE_SCALE

    chart = tmp_path / "chart"
    shutil.copytree(FRANCIS_DIR, chart)
    (chart / "nets.json").unlink()
    lines = (chart / "flow.csv").read_text(encoding="utf-8").splitlines()
    kept = [row for row in lines[1:] if float(row.split(",")[0]) in (10.0, 20.0, 30.0)]
    (chart / "flow.csv").write_text("\n".join([lines[0]] + kept) + "\n", encoding="utf-8")
    out = tmp_path / "nets.json"
    assert main(["train", str(chart), "--out", str(out), "--ensemble", "2"]) == 0
    assert "no held-out evidence (fewer than 4 opening lines)" in capsys.readouterr().out
    band = json.loads(out.read_text(encoding="utf-8"))["silent_model"]["band"]
    assert band["distance_cap"] == NO_EVIDENCE_CAP and band["q11"] == [NO_EVIDENCE_SCALE, NO_EVIDENCE_SCALE]
