"""Paper 003's analyses (hillchart.fccm) and ``hillsim fccm``: grey relations, image similarity, maps, the truth
comparison and its acceptance."""

import json

import numpy as np
import pytest
from scipy.spatial import distance

from hillchart.synthetic.bulb import write_bulb_table
from hillchart.errors import InputError
from hillchart.fccm.analysis import analyse_fccm
from hillchart.fccm.maps import (efficiency_maps, grey_images, grey_relational_analysis, image_similarity,
                                 read_truth_csv, truth_acceptance, truth_comparison)
from hillchart.fccm.net import FCCMNet, load_fccm_nets
from hillchart.fccm.table import load_test_table
from hillsim.cli import main

INPUTS = "blade_angle_deg,guide_vane_deg"
OUTPUTS = "efficiency,head_m,power_kw,flow_m3_s"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """``hillsim synth --turbine bulb`` (noise 0.3 %, 150 points, seed 0) then ``hillsim fccm`` with the truth."""
    base = tmp_path_factory.mktemp("fccm")
    assert main(["synth", str(base / "table"), "--turbine", "bulb"]) == 0
    assert main(["fccm", str(base / "table"), "--inputs", INPUTS, "--outputs", OUTPUTS, "--out", str(base / "out"),
                 "--truth", str(base / "table" / "truth.csv")]) == 0
    metrics = json.loads((base / "out" / "metrics.json").read_text())
    return base, metrics


def direct_grey_relational(table_path, outputs, controls, rho=0.5):
    """Table 1 computed straight from the CSV with loops (independent of hillchart.fccm)."""
    data = np.genfromtxt(table_path, delimiter=",", names=True)
    out = {}
    for o in outputs:
        x0 = (data[o] - data[o].min()) / (data[o].max() - data[o].min())
        deltas = {}
        for c in controls:
            xi = (data[c] - data[c].min()) / (data[c].max() - data[c].min())
            deltas[c] = [abs(a - b) for a, b in zip(x0, xi)]
        d_min = min(min(v) for v in deltas.values())
        d_max = max(max(v) for v in deltas.values())
        out[o] = {c: sum((d_min + rho * d_max) / (d + rho * d_max) for d in v) / len(v) for c, v in deltas.items()}
    return out


@pytest.mark.slow
def test_grey_relational_degrees_equal_a_direct_computation(run):
    base, metrics = run
    direct = direct_grey_relational(base / "table" / "table.csv", OUTPUTS.split(","), INPUTS.split(","))
    for o, row in direct.items():
        for c, value in row.items():
            assert metrics["grey_relational"][o][c] == pytest.approx(value, abs=1e-12)  # same sums, other order


@pytest.mark.slow
def test_grey_relational_order_follows_the_physics(run):
    """Flow and power follow the blade angle: turning the blades sets the runner's exit angle and with it the
    flow the runner swallows (7.2 x over the blade range at beta = 59 deg, against 2.1 x over the guide-vane range
    at a0 = 0, tests/hillchart/synthetic/test_bulb.py), and power follows flow. Head (which falls with flow on the water
    system) and efficiency (humped) are not monotone in either control: their degrees stay near 0.65, the degree of
    unrelated uniform sequences (1.5 ln 3 - 1), so their order carries little information."""
    _, metrics = run
    order = metrics["grey_relational_order"]
    assert order["flow_m3_s"]["blade_angle_deg"] == 1 and order["power_kw"]["blade_angle_deg"] == 1
    gra = metrics["grey_relational"]
    assert gra["flow_m3_s"]["blade_angle_deg"] > gra["flow_m3_s"]["guide_vane_deg"] + 0.1
    for o in ("efficiency", "head_m"):
        for c in INPUTS.split(","):
            assert abs(gra[o][c] - (1.5 * np.log(3) - 1)) < 0.1


def test_unrelated_sequences_give_the_baseline_degree():
    """The 'no relation' level of GRA: for independent uniform sequences the degree tends to 1.5 ln 3 - 1 = 0.648."""
    rng = np.random.default_rng(0)
    r = grey_relational_analysis({"y": rng.uniform(size=20000)}, {"x": rng.uniform(size=20000)})
    assert r["y"]["x"] == pytest.approx(1.5 * np.log(3) - 1, abs=0.01)  # 20000 samples: standard error ~0.002


def test_similarity_metrics_match_scipy_and_identical_maps():
    rng = np.random.default_rng(1)
    a = rng.uniform(0.6, 0.9, (40, 50))
    b = a + rng.normal(0, 0.01, a.shape)
    ga, gb, mask = grey_images(a, b)
    s = image_similarity(ga, gb, mask)
    ha, hb = np.array(s["histogram_a"]), np.array(s["histogram_b"])
    assert ha.size == 25 and ha.sum() == pytest.approx(1.0, abs=1e-15)
    assert s["euclidean"] == pytest.approx(distance.euclidean(ha, hb), abs=1e-15)  # eq. (4)
    assert s["cosine"] == pytest.approx(1 - distance.cosine(ha, hb), abs=1e-15)  # eq. (5)
    same = image_similarity(ga, ga, mask)
    assert same["euclidean"] == 0.0 and same["cosine"] == 1.0 and same["angle_deg"] == 0.0 and same["pixel_rms"] == 0.0


def test_a_shifted_map_has_the_same_histogram_but_a_pixel_difference():
    """Why the pixel RMS is the measure to trust: a map against itself shifted by a quarter period (wrapped) has
    exactly the same grey levels in other places: histogram distance 0, cosine 1, but a large pixel RMS; shifted
    without wrapping by 3 pixels the histogram distance stays near 0."""
    x = np.linspace(0, 4 * np.pi, 200, endpoint=False)
    eta = 0.8 + 0.1 * np.sin(x)[None, :] * np.ones((60, 1))
    shifted = np.roll(eta, 50, axis=1)
    ga, gb, mask = grey_images(eta, shifted)
    s = image_similarity(ga, gb, mask)
    assert s["euclidean"] == 0.0 and s["cosine"] == 1.0
    assert s["pixel_rms"] > 100  # 255 (sin - cos)/2 has RMS 255/2 = 127
    smooth = 0.8 + 0.1 * np.outer(np.linspace(0, 1, 80), np.linspace(0, 1, 120))
    ga, gb, mask = grey_images(smooth[:, 3:], smooth[:, :-3])
    s = image_similarity(ga, gb, mask)
    assert s["euclidean"] < 0.05 and s["pixel_rms"] > 2.0


def test_grey_images_share_mapping_and_mask():
    a = np.array([[0.5, 0.6, np.nan], [0.6, 0.8, 0.9]])
    b = np.array([[0.5, np.nan, 0.7], [0.6, 0.9, 0.9]])
    ga, gb, mask = grey_images(a, b)
    assert mask.tolist() == [[True, False, False], [True, True, True]]
    assert ga[0, 0] == 0 and ga[1, 2] == 255 and gb[1, 1] == 255  # one mapping 0.5 -> 0, 0.9 -> 255
    assert ga[1, 0] == gb[1, 0] == 64  # 255 * 0.1 / 0.4 = 63.75
    with pytest.raises(InputError, match="same shape"):
        grey_images(a, b[:, :2])
    with pytest.raises(InputError, match="no pixel"):
        grey_images(np.full((2, 2), np.nan), b[:, :2])


@pytest.mark.slow
def test_fccm_command_writes_everything(run):
    base, metrics = run
    out = base / "out"
    for name in ("fccm_nets.json", "metrics.json", "fccm_efficiency_maps.png", "fccm_control_maps.png",
                 "fccm_operating_characteristic.png"):
        assert (out / name).is_file()
    assert not list(out.glob(".fccm-*"))  # no temporary folder left
    weights = load_fccm_nets(out / "fccm_nets.json")
    assert weights.inputs == tuple(INPUTS.split(",")) and weights.hidden == metrics["hidden"]
    assert set(metrics["similarity"]) >= {"euclidean", "cosine", "angle_deg", "pixel_rms"}
    for o in OUTPUTS.split(","):
        assert set(metrics["errors"][o]) == {"train", "validation", "test"}
    assert 3 <= metrics["hidden"] <= 12 and 1 <= metrics["c"] <= 10


@pytest.mark.slow
def test_acceptance_on_the_synthetic_bulb(run):
    """Accuracy bounds: each output's RMS on the dense truth grid <= 1.5 % of its range, the net below linear
    interpolation for >= 3 of 4 outputs (seed 0; measured 1.43 / 0.57 / 1.03 / 0.37 % against 5.5 / 2.1 / 5.5 /
    2.0 %)."""
    _, metrics = run
    assert metrics["acceptance"]["passed"], metrics["truth"]
    assert metrics["truth"]["points_outside_hull"] == 0  # the corners are test points: interpolation covers all


@pytest.mark.slow
def test_the_acceptance_check_can_fail(run):
    """The same check on a net with one hidden neuron fails (it cannot bend the efficiency hump)."""
    base, _ = run
    table = load_test_table(base / "table")
    ins, outs = INPUTS.split(","), OUTPUTS.split(",")
    net = FCCMNet(hidden=1, restarts=1, seed=0).fit(table.matrix(ins), table.matrix(outs), input_names=ins,
                                                     output_names=outs)
    comparison = truth_comparison(net.weights_, table, read_truth_csv(base / "table" / "truth.csv"))
    result = truth_acceptance(comparison, outs)
    assert not result["passed"] and not result["within_bound"]["efficiency"]


@pytest.mark.slow
def test_best_efficiency_table_gives_a_two_dimensional_fccm_map(tmp_path):
    """With the best-efficiency closure the settings cover a 2-D region of (Q11, n11): the maps overlap on
    thousands of pixels (on the water system they lie on one curve)."""
    write_bulb_table(tmp_path, seed=0, closure="best-efficiency")
    table = load_test_table(tmp_path)
    ins, outs = INPUTS.split(","), OUTPUTS.split(",")
    report = analyse_fccm(table, ins, outs, net=FCCMNet(hidden=10, restarts=2, seed=0))
    assert report.metrics["similarity"]["pixels"] > 5000
    maps = efficiency_maps(table, report.weights)
    diff = np.abs(maps.net[maps.mask] - maps.interpolated[maps.mask])
    # the two maps agree on most pixels (median within 0.01 of efficiency, the range is 0.15); the largest
    # differences (0.1) sit where the (a0, beta) -> (Q11, n11) mapping folds and the test points crowd
    assert np.median(diff) < 0.01


@pytest.mark.slow
@pytest.mark.parametrize("argv, message", [
    (["--inputs", "blade_angle_deg,gv"], "no numeric column 'gv'"),
    (["--inputs", "blade_angle_deg,"], "--inputs must be comma-separated column names"),
    (["--outputs", "efficiency,blade_angle_deg"], "both inputs and outputs"),
    (["--split", "0.5,0.5"], "--split must be three"),
    (["--split", "0.5,0.4,0.4"], "split must be three fractions in \\(0, 1\\) summing to 1"),
    (["--hidden", "0"], "--hidden must be an integer within 1-100, got 0"),
    (["--restarts", "0"], "--restarts must be an integer >= 1"),
    (["--truth", "nowhere.csv"], "missing file"),
])
def test_bad_cli_options_leave_nothing(run, tmp_path, capsys, argv, message):
    base, _ = run
    args = {"--inputs": INPUTS, "--outputs": OUTPUTS}
    for k, v in zip(argv[::2], argv[1::2]):
        args[k] = v
    flat = [item for kv in args.items() for item in kv]
    assert main(["fccm", str(base / "table"), "--out", str(tmp_path / "o"), *flat]) == 2
    import re
    assert re.search(message, capsys.readouterr().err)
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_a_failing_figure_leaves_no_output_folder(run, tmp_path):
    base, _ = run
    table = load_test_table(base / "table")
    report = analyse_fccm(table, INPUTS.split(","), OUTPUTS.split(","), net=FCCMNet(hidden=4, restarts=1))

    def broken(path):
        raise RuntimeError("figure failed")

    report.figures["fccm_control_maps.png"] = broken
    with pytest.raises(RuntimeError, match="figure failed"):
        report.write(tmp_path / "o")
    assert not (tmp_path / "o").exists()
    written = report.write(tmp_path / "o", plots=False)
    assert sorted(p.name for p in (tmp_path / "o").iterdir()) == sorted(written) == ["fccm_nets.json", "metrics.json"]
