"""Identification on the nonlinear simulator vs the nets' linear model (the acceptance bounds) and ``hillsim identify``.

The shipped HLA339-like plant with the shipped synthetic nets, operating near rated opening (stroke 0.68, ~225 MW).
A shortened experiment (steps held 25 s, 60 s of PRBS, 40 s quiet) keeps each run to a few seconds.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("simulate.loop.engine")

from data_synthetic import FRANCIS_DIR  # noqa: E402
from hillchart.synthetic.francis import SyntheticFrancis  # noqa: E402
from hillsim.cli import main  # noqa: E402
from simulate.identification.experiment import ExperimentSettings  # noqa: E402
from simulate.identification.compare import compare_identification  # noqa: E402
from simulate.config import load_plant  # noqa: E402
from simulate.identification.results import ArmaSkipped  # noqa: E402

PLANT_FILE = FRANCIS_DIR.parent / "plant_hla339.toml"
SHORT = ExperimentSettings(step_hold_s=25.0, prbs_duration_s=60.0, quiet_s=40.0)
STROKE = 0.68


@pytest.fixture(scope="module")
def plant():
    return load_plant(PLANT_FILE)


@pytest.fixture(scope="module")
def reports(plant):
    return {model: compare_identification(plant, settings=SHORT, exact=SyntheticFrancis(), penstock_model=model,
                                          initial_opening=STROKE)
            for model in ("rigid", "lumped", "moc")}


@pytest.mark.parametrize("model", ["rigid", "lumped"])
def test_acceptance_with_the_matching_penstock_model(reports, model):
    s = reports[model].summary
    six = s.six_coefficients
    # batch LS of the six coefficients within 0.02 of the nets' analytic values (measured ~0.004: the residual is
    # the nonlinearity of +-1 % steps, mostly in ex and eqx)
    assert six.max_abs_batch_ls_minus_nets < 0.02
    # step response of the RLS-identified ARX vs the ZOH of the nets' linear plant: within 5 % of peak
    # (measured ~0.3 %)
    assert s.arx.rls.step_error_vs_nets < 0.05
    # simulation-mode speed error (eqs. 62-64) below 1 % (measured ~4e-5 absolute)
    assert s.arx.rls.simulation_mode_final_theta.max_abs_error < 0.01
    assert all(check.passed is True for check in s.acceptance.checks())
    # each check carries the number it judged and its bound: the same numbers as above
    assert s.acceptance.batch_ls.value == six.max_abs_batch_ls_minus_nets and s.acceptance.batch_ls.bound == 0.02
    assert s.acceptance.rls_step_response.value == s.arx.rls.step_error_vs_nets
    assert s.acceptance.rls_simulation_mode.bound == 0.05  # a fraction of the largest speed deviation
    # and the nets agree with the exact turbine the chart was drawn from (coefficients within 0.05)
    assert six.max_abs_nets_minus_exact < 0.05
    # the linear model is the one that matches the simulator's penstock
    assert s.linear_model.startswith("inelastic" if model == "rigid" else "elastic")


def test_moc_difference_is_reported_and_static_coefficients_do_not_depend_on_it(reports):
    moc, lumped = reports["moc"].summary, reports["lumped"].summary
    # the six coefficients are static: batch LS agrees with the nets whatever the penstock model
    assert moc.six_coefficients.max_abs_batch_ls_minus_nets < 0.02
    # MOC has the travelling waves the lumped model lumps into one mode: its own first step still follows the
    # lumped prediction closely (measured 2.6 % vs 1.4 % for lumped), the identified 3rd-order ARX less so
    assert moc.simulated_step_vs_nets.max_error_frac_of_peak < 0.05
    assert lumped.simulated_step_vs_nets.max_error_frac_of_peak < 0.03
    assert np.isfinite(moc.arx.rls.step_error_vs_nets)
    assert moc.acceptance.rls_step_response.passed is None  # reported, not judged, for moc
    # why: the travelling waves need more ARX order at tau = 0.2 s. Batch-LS ARX of order 6 follows the nets'
    # lumped model within 5 % (measured 2.2 %), order 3 does not (measured 11.5 %); for lumped data order 3 suffices
    sweep = {row.order: row for row in moc.arx_order_sweep}
    assert sweep[6].step_error_vs_nets < 0.05 < sweep[3].step_error_vs_nets
    assert {row.order: row for row in lumped.arx_order_sweep}[3].step_error_vs_nets < 0.01


def test_paper_002_arma_on_the_rigid_run(reports):
    arma = reports["rigid"].summary.arma_paper002
    eff = arma.nets_with_friction
    # backward-difference eq. (6) at Dt = 0.04 s is biased by ~Dt / (2 eqh Tw) ~ 3 %; eqx x is neglected:
    # measured differences 0.002 (ey), 0.04 (e), 0.004 (eqh)
    assert abs(arma.ey - eff.ey) < 0.02
    assert abs(arma.e - eff.e) < 0.1
    assert abs(arma.eqh - eff.eqh) < 0.02
    assert isinstance(reports["lumped"].summary.arma_paper002, ArmaSkipped)  # paper 002 is a rigid-water model


def test_dead_zone_keeps_theta_bounded_where_forgetting_rls_drifts_on_the_simulator(plant):
    noisy = ExperimentSettings(step_hold_s=25.0, prbs_duration_s=60.0, quiet_s=80.0, noise_level=2e-5, seed=3)
    s = compare_identification(plant, settings=noisy, penstock_model="lumped", initial_opening=STROKE).summary
    arx = s.arx
    # in the quiet tail only noise drives the estimators: forgetting RLS winds up and wanders (O(1) in theta),
    # the dead zone does not move (measured 0 vs ~2)
    assert arx.rls_forgetting.theta_spread_quiet_tail > 0.3
    assert arx.dead_zone_rls.theta_spread_quiet_tail < 0.1 * arx.rls_forgetting.theta_spread_quiet_tail
    # the noisy data still gives the six coefficients (batch LS is not an equation-error ARX fit)
    assert s.six_coefficients.max_abs_batch_ls_minus_nets < 0.02


def test_report_writes_json_and_figures(reports, tmp_path):
    paths = reports["lumped"].write(tmp_path)
    data = json.loads(paths["json"].read_text())
    check = data["acceptance"]["rls_step_response"]
    assert data["penstock_model"] == "lumped" and check["name"] == "rls_step_response_within_5pct"
    assert check["passed"] is True and check["bound"] == 0.05
    # the file is the record: every number in it is the record's (to_json_dict of the summary)
    assert check["value"] == reports["lumped"].summary.arx.rls.step_error_vs_nets
    assert data["six_coefficients"]["batch_ls"]["ex"] == reports["lumped"].summary.six_coefficients.batch_ls.ex
    assert [row["order"] for row in data["arx_order_sweep"]] == [2, 3, 4, 5, 6]
    for key in ("series_png", "six_png", "step_png", "theta_png", "simulation_mode_png"):
        assert paths[key].stat().st_size > 5_000
    series = np.loadtxt(paths["series"], delimiter=",", skiprows=1)
    assert series.shape[1] == 6 and np.allclose(np.diff(series[:, 0]), 0.2)


def test_identify_cli(tmp_path, capsys):
    out = tmp_path / "ident"
    argv = ["identify", str(PLANT_FILE), "--out", str(out), "--penstock-model", "rigid", "--initial-opening",
            str(STROKE), "--step-hold-s", "20", "--prbs-duration-s", "40", "--quiet-s", "20", "--no-plot"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert not list(out.glob("*.png"))  # --no-plot: the figures are tested in test_report_writes_json_and_figures
    assert "| ex |" in text and "batch_ls_within_0.02_of_nets | PASS" in text
    data = json.loads((out / "identification.json").read_text())
    assert data["experiment"]["step_hold_s"] == 20.0
    # the measured-data path on the simulator's own output gives the same batch-LS coefficients
    sim_csv = tmp_path / "run.csv"
    from simulate.identification.experiment import experiment_plant
    from simulate.loop.engine import run_simulation

    plant = load_plant(PLANT_FILE)
    settings = ExperimentSettings(step_hold_s=20.0, prbs_duration_s=40.0, quiet_s=20.0)
    run_simulation(experiment_plant(plant, settings, initial_stroke=STROKE, penstock_model="rigid")).to_csv(sim_csv)
    assert main(["identify", str(PLANT_FILE), "--out", str(tmp_path / "measured"), "--data", str(sim_csv),
                 "--no-plot"]) == 0
    measured = json.loads((tmp_path / "measured" / "identification.json").read_text())
    for k in ("ex", "ey", "eh", "eqx", "eqy", "eqh"):
        # same data, same regression: equal to round-off of the CSV (10 significant digits)
        assert measured["six_coefficients"]["batch_ls"][k] == pytest.approx(
            data["six_coefficients"]["batch_ls"][k], abs=1e-6)


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--tau", "0"], "experiment.sample_time_s"),
        (["--amplitude", "0.5"], "experiment.step_amplitude"),
        (["--initial-opening", "1.7"], "initial_opening must be a stroke fraction"),
        (["--set", "penstock.model=pipe"], "penstock.model"),
        (["--data", "x.csv", "--penstock-model", "rigid"], "apply to the simulated experiment"),
    ],
)
def test_identify_cli_bad_options(extra, message, tmp_path, capsys):
    assert main(["identify", str(PLANT_FILE), "--out", str(tmp_path / "o"), *extra]) == 2
    err = capsys.readouterr().err
    last = err.splitlines()[-1]  # a progress start line may precede it
    assert last.startswith("hillsim identify: error:") and message in last and "Traceback" not in err


def test_a_double_regulated_unit_is_identified_against_its_coefficients_on_the_cam():
    """The bulb plant's reference is the nets' six coefficients on its cam (over the guide-vane opening, the blades
    following). With a blade servo fast enough to keep the blades on the cam, batch LS finds them; with the plant's
    own 1 s servo it does not, and says why instead of failing."""
    from data_synthetic import PLANT_BULB

    settings = ExperimentSettings(step_hold_s=25.0, prbs_duration_s=60.0, quiet_s=40.0)
    fast = compare_identification(load_plant(PLANT_BULB, {"blade_servo.servo_time_s": 0.02}), settings=settings)
    own = compare_identification(load_plant(PLANT_BULB), settings=settings)
    six_fast, six_own = fast.summary.six_coefficients, own.summary.six_coefficients
    # the same reference (the same operating point, so the same coefficients on the cam)
    assert six_fast.nets == six_own.nets
    # measured: 0.058 (the remaining nonlinearity and the draft tube) against 0.36 with the lagging blades
    assert six_fast.max_abs_batch_ls_minus_nets < 0.1 < 0.2 < six_own.max_abs_batch_ls_minus_nets
    check = own.summary.acceptance.batch_ls
    assert check.passed is None and check.value == six_own.max_abs_batch_ls_minus_nets
    assert check.reason.startswith("the blades follow the cam through their servo (blade_servo.servo_time_s = 1 s)")
    # the step responses are not judged either (nor would they be on the rigid column's linear model)
    assert all(c.passed is None for c in own.summary.acceptance.checks() if "step_response" in c.name)
