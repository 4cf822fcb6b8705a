"""Acceptance that can fail: identification errors judged relative to the experiment."""

from data_synthetic import PLANT_HLA339
from simulate.config import load_plant
from simulate.identification.experiment import ExperimentSettings
from simulate.identification.compare import compare_identification
from simulate.identification.results import SIMULATION_MODE_TOLERANCE
from simulate.identification.tables import markdown_tables

PLANT = load_plant(PLANT_HLA339)


def _summary(**kw):
    return compare_identification(PLANT, settings=ExperimentSettings(**kw), penstock_model="lumped",
                                  initial_opening=0.68).summary


def test_noisy_identification_that_is_119_percent_off_fails_and_the_noise_free_one_passes():
    noisy = _summary(noise_level=2e-5, seed=3)  # docs/identification.md: forgetting RLS 119 % off in step response
    forgetting = noisy.arx.rls_forgetting
    assert forgetting.step_error_vs_nets > 1.0  # measured 1.19
    sim = forgetting.simulation_mode_final_theta
    # the old bound (0.01 pu absolute) passed it: the largest speed deviation of the experiment is only 0.0024 pu
    assert sim.max_abs_error < 0.01
    # relative to the experiment the simulation-mode error is the whole response (measured 100 % of the peak)
    assert sim.relative_error > SIMULATION_MODE_TOLERANCE
    acc = noisy.acceptance
    assert acc.rls_forgetting_step_response.passed is False
    assert acc.rls_forgetting_simulation_mode.passed is False
    assert acc.dead_zone_rls_simulation_mode.passed is False  # 129 % off in step, 104 % sim. mode
    assert "FAIL" in markdown_tables(noisy)
    clean = _summary(step_hold_s=25.0, prbs_duration_s=60.0, quiet_s=40.0)
    # noise-free: simulation-mode errors 1.7-1.9 % of the peak, step errors 0.2-0.8 %: every check passes
    assert all(check.passed is True for check in clean.acceptance.checks())
    assert "FAIL" not in markdown_tables(clean)
    for name in ("rls", "rls_forgetting", "dead_zone_rls"):
        assert getattr(clean.arx, name).simulation_mode_final_theta.relative_error < 0.025
