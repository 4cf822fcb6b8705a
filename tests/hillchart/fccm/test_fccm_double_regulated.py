"""Beyond paper 003: three-input nets Q11(N11, a, phi), M11(N11, a, phi) of the synthetic bulb and the on-cam
relation phi(a, H) derived from them."""

import json

import numpy as np
import pytest

from hillchart.synthetic.bulb import SyntheticBulb
from hillchart.errors import InputError, NumericalError
from hillchart.fccm.double_regulated import (DoubleRegulatedNets, bulb_chart_samples, load_double_regulated_nets,
                                             on_cam_relation, plot_on_cam, train_double_regulated_nets)
from hillchart.nets.hill_nets import load_nets


@pytest.fixture(scope="module")
def trained():
    bulb = SyntheticBulb()
    nets = train_double_regulated_nets(bulb_chart_samples(bulb, seed=0), seed=0)
    return bulb, nets


def test_three_input_nets_match_the_synthetic_bulb(trained):
    """600 chart samples, 3-15-1 nets: measured RMS 0.09 % (Q11) and 0.06 % (M11) of the range, max 0.5 %."""
    bulb, nets = trained
    rng = np.random.default_rng(5)
    n11, gv, blade = rng.uniform(110, 230, 4000), rng.uniform(40, 78, 4000), rng.uniform(-18, 16, 4000)
    for name in ("q11", "m11"):
        exact = getattr(bulb, name)(n11, gv, blade)
        err = getattr(nets, name)(n11, gv, blade) - exact
        assert np.sqrt(np.mean(err ** 2)) < 0.003 * np.ptp(exact)  # 0.3 %: 3x the measured RMS
        assert np.max(np.abs(err)) < 0.015 * np.ptp(exact)  # 1.5 %: 3x the measured max


def test_net_format_round_trip_and_the_two_input_loader_refuses_it(trained, tmp_path):
    _, nets = trained
    path = nets.save(tmp_path / "bulb_nets.json")
    doc = json.loads(path.read_text())
    assert doc["format"] == "hillsim.nets" and doc["units"]["blade_angle"] == "deg"
    assert doc["flow"]["inputs"] == ["n11", "opening", "blade_angle"] and doc["torque"]["output"] == "m11"
    assert len(doc["flow"]["W1"][0]) == 3 and isinstance(doc["flow"]["b2"], float)
    back = load_double_regulated_nets(path)
    assert back.flow == nets.flow and back.torque == nets.torque and back.to_json() == path.read_text()
    # today's two-input loader must not silently take a three-input chart
    with pytest.raises(InputError, match="flow.inputs must be"):
        load_nets(path)


@pytest.mark.parametrize("edit, message", [
    (lambda d: d["flow"].update(inputs=["n11", "opening"]), "flow.inputs must be"),
    (lambda d: d["torque"].update(output="q11"), "torque.output must be 'm11'"),
    (lambda d: d["flow"].pop("W1"), "flow.W1 is missing"),
    (lambda d: d["flow"].update(b2=float("nan")), "flow.b2 must be finite"),
    (lambda d: d["flow"]["W1"][0].pop(), r"flow.W1\[0\] must have 3 entries"),
    (lambda d: d["units"].update(blade_angle="rad"), "units must hold"),
    (lambda d: d.update(version=2), "version must be 1"),
])
def test_malformed_three_input_files(trained, tmp_path, edit, message):
    _, nets = trained
    doc = nets.to_dict()
    edit(doc)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError, match=message):
        load_double_regulated_nets(path)


def test_analytic_gradients_match_central_differences(trained):
    _, nets = trained
    point = (160.0, 55.0, -3.0)
    for name in ("q11", "m11"):
        grad = getattr(nets, f"{name}_grad")(*point)
        for j, h in enumerate((1e-3, 1e-4, 1e-4)):
            up, down = list(point), list(point)
            up[j] += h
            down[j] -= h
            fd = (getattr(nets, name)(*up) - getattr(nets, name)(*down)) / (2 * h)
            assert float(grad[j]) == pytest.approx(float(fd), rel=1e-5, abs=1e-9)


def test_on_cam_refinement_is_exact_for_a_quadratic():
    """eta = 0.9 - (phi - phi*)^2 / 100 with phi* = a / 10 + H / 5 - 9: the parabola vertex is exact."""
    def eta(n11, a, phi):
        head = (100.0 * 2.0 / n11) ** 2
        return 0.9 - (phi - (a / 10 + head / 5 - 9)) ** 2 / 100
    cam = on_cam_relation(eta, [40.0, 55.3, 70.0], [8.0, 12.0], speed_rpm=100.0, runner_diameter_m=2.0)
    expected = np.array([[a / 10 + h / 5 - 9 for a in (40.0, 55.3, 70.0)] for h in (8.0, 12.0)])
    np.testing.assert_allclose(cam["blade_angle"], expected, atol=1e-9)
    np.testing.assert_allclose(cam["efficiency"], 0.9, atol=1e-12)
    assert not cam["at_bound"].any()


def test_on_cam_holds_the_nearest_cam_where_no_blade_angle_passes_water():
    """Near the closed vane nets may give Q11 <= 0 (efficiency NaN) at every blade angle: the cam there is the
    nearest flowing opening's, flagged ``held``; with no flow at any opening of a head the cam is refused."""
    def eta(n11, a, phi):
        value = 0.9 - (phi - (a / 10 - 5)) ** 2 / 100
        return np.where(np.broadcast_to(a, np.broadcast_shapes(np.shape(n11), np.shape(a), np.shape(phi))) < 45.0,
                        np.nan, value)
    cam = on_cam_relation(eta, [40.0, 44.0, 50.0, 60.0], [10.0], speed_rpm=100.0, runner_diameter_m=2.0)
    np.testing.assert_array_equal(cam["held"], [[True, True, False, False]])
    np.testing.assert_allclose(cam["blade_angle"], [[0.0, 0.0, 0.0, 1.0]], atol=1e-9)  # 50 deg's cam held below
    assert np.isnan(cam["efficiency"][0, :2]).all()
    with pytest.raises(NumericalError, match="Q11 <= 0 at every opening and blade angle of a head"):
        on_cam_relation(eta, [40.0, 44.0], [10.0], speed_rpm=100.0, runner_diameter_m=2.0)


def test_on_cam_from_the_nets_follows_the_exact_one(trained, tmp_path):
    """Over a = 40-78 deg and H = 8-14 m the nets' cam is within 1.5 deg of the exact one (measured max 1.1 deg,
    where efficiency is flat in phi, so a small error in eta moves its optimum far) and its efficiency within 0.012
    (measured 0.006; 2x margin)."""
    bulb, nets = trained
    p = bulb.params
    kw = dict(speed_rpm=p.speed_rpm, runner_diameter_m=p.runner_diameter_m)
    openings, heads = np.linspace(40, 78, 39), [8.0, 10.0, 12.0, 14.0]
    cam = on_cam_relation(nets.efficiency, openings, heads, **kw)
    exact = on_cam_relation(bulb.unit_efficiency, openings, heads, **kw)
    assert np.max(np.abs(cam["blade_angle"] - exact["blade_angle"])) < 1.5
    assert np.max(np.abs(cam["efficiency"] - exact["efficiency"])) < 0.012
    assert np.all(np.diff(exact["blade_angle"][:, :20], axis=1) > 0)  # the cam opens the blades with the vanes
    assert plot_on_cam(cam, exact, tmp_path / "cam.png").stat().st_size > 10000
    via_method = nets.on_cam(openings, heads, **kw)
    np.testing.assert_array_equal(via_method["blade_angle"], cam["blade_angle"])
    assert not via_method["outside_domain"].any()  # n11 138-183 r/min inside the fitted 110-230
    with pytest.warns(UserWarning, match="outside the nets' fitted box"):
        far = nets.on_cam(openings, [3.0, 10.0], **kw)  # H = 3 m: n11 = 299 r/min
    assert far["outside_domain"].tolist() == [True, False]
    with pytest.raises(InputError, match="heads_m must be > 0"):
        on_cam_relation(nets.efficiency, openings, [0.0], **kw)
    with pytest.raises(InputError, match="3-input"):
        DoubleRegulatedNets(flow=nets.flow, torque="x")


def test_evaluating_the_three_input_nets_does_not_import_torch(trained, tmp_path):
    import subprocess
    import sys
    from pathlib import Path

    repo = Path(__file__).resolve().parents[3]
    path = trained[1].save(tmp_path / "bulb_nets.json")
    code = ("import sys; from hillchart.fccm.double_regulated import load_double_regulated_nets as L; "
            "n = L(sys.argv[1]); "
            "n.efficiency(160.0, 55.0, 0.0); n.q11_grad(160.0, 55.0, 0.0); "
            "assert 'torch' not in sys.modules, 'torch was imported'")
    done = subprocess.run([sys.executable, "-c", code, str(path)], cwd=repo, capture_output=True, text=True,
                          env={"PYTHONPATH": str(repo), "PATH": "/usr/bin:/bin"})
    assert done.returncode == 0, done.stderr
