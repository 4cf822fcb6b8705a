"""Real double-regulated / bulb data through hillchart.fccm (skips when ../shared/external is absent)."""

import json

import numpy as np
import pytest

from hillchart.fccm.table import load_test_table
from hillsim.cli import main
from tests.fccm_external import write_bulb_137kw_table, write_kaplan_table

pytestmark = [pytest.mark.external, pytest.mark.slow]  # external: reads ../shared/external; skips when it is absent


@pytest.fixture(scope="module")
def bulb(tmp_path_factory):
    base = tmp_path_factory.mktemp("bulb137")
    write_bulb_137kw_table(base / "table")
    assert main(["fccm", str(base / "table"), "--inputs", "guide_vane_deg,head_m", "--outputs",
                 "efficiency,power_kw,flow_m3_s", "--out", str(base / "out")]) == 0
    return base, json.loads((base / "out" / "metrics.json").read_text())


def test_bulb_loader_derives_the_files_unit_quantities(bulb):
    base, _ = bulb
    table = load_test_table(base / "table")
    assert table.n_rows == 72 and table.derived == ("n11_rpm", "q11_m3_s")
    # the file's own n11 / Q11 (4-5 decimals) equal eqs. (1)-(2) with D = 0.4 m, 1000 r/min
    np.testing.assert_allclose(table.column("n11_rpm"), table.column("n11_file"), atol=1e-4)
    np.testing.assert_allclose(table.column("q11_m3_s"), table.column("q11_file"), atol=1e-5)


def test_bulb_trains_and_is_plausible(bulb):
    """72 points (22 for training): the net reproduces the held-out test points within a few % of each output's
    range; flow and power follow the guide vane (fixed blades), efficiency falls as the vanes open beyond 40 deg."""
    base, metrics = bulb
    table = load_test_table(base / "table")
    for o in ("efficiency", "power_kw", "flow_m3_s"):
        span = np.ptp(table.column(o))
        assert metrics["errors"][o]["test"]["rmse"] < 0.05 * span, (o, metrics["errors"][o])
    assert metrics["similarity"]["pixels"] > 1000  # 8 heads x GV sweep: a 2-D region of (Q11, n11)
    for name in ("fccm_efficiency_maps.png", "fccm_control_maps.png", "fccm_operating_characteristic.png"):
        assert (base / "out" / name).is_file()


def test_kaplan_chart_trains(tmp_path):
    write_kaplan_table(tmp_path / "table")
    assert main(["fccm", str(tmp_path / "table"), "--inputs", "blade_angle_deg,n11_rpm", "--outputs",
                 "q11_m3_s,efficiency", "--out", str(tmp_path / "out")]) == 0
    metrics = json.loads((tmp_path / "out" / "metrics.json").read_text())
    table = load_test_table(tmp_path / "table")
    for o in ("q11_m3_s", "efficiency"):
        assert metrics["errors"][o]["test"]["rmse"] < 0.05 * np.ptp(table.column(o)), (o, metrics["errors"][o])
    # in a Kaplan chart the unit flow follows the blade angle (the blades set the swallowing capacity)
    assert metrics["grey_relational_order"]["q11_m3_s"]["blade_angle_deg"] == 1
