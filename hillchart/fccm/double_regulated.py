"""Beyond Wu et al.: a three-input hill chart Q11(N11, a, phi), M11(N11, a, phi) of a double-regulated turbine and its
on-cam relation.

This module makes the nets: from samples of the synthetic bulb (:func:`bulb_chart_samples`,
:func:`train_double_regulated_nets`, the shipped nets of :func:`write_bulb_nets`) or from a user's test table
(:func:`table_unit_samples`, :func:`extend_unit_samples`, :func:`train_table_nets`). The nets themselves, their file
and the on-cam relation are :mod:`hillchart.fccm.three_input_nets`; the fitted bulb model that answers where the
table is silent and the compiled evaluation of the blend are :mod:`hillchart.fccm.bulb_silent_model`. Their names
are importable from here as well.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hillchart.errors import InputError
from hillchart.extension.residual import continued_residual
from hillchart.fccm.bulb_silent_model import (BLEND_START_FRACTION, NET3_INPUTS, NO_BLEND, SILENT_KIND, WEIGHED,
                                              BulbSilentModel, blended_point, blended_value, net3_point,
                                              packed_net3, weighed_point)
from hillchart.fccm.evidence import BulbExtrapolation
from hillchart.fccm.net import FCCMNet
from hillchart.fccm.three_input_nets import (DoubleRegulatedNets, load_double_regulated_nets, on_cam_relation,
                                             plot_on_cam)


def bulb_chart_samples(turbine=None, *, n_points: int = 600, seed: int = 0, n11_range=(110.0, 230.0),
                       opening_range=None) -> dict:
    """Scattered samples of the synthetic bulb's unit characteristic (its 'chart'): the 8 corners of the box plus a
    seeded Latin hypercube over n11 (r/min), guide-vane angle (``opening_range``, default the paper's range) and
    blade angle (the paper's range), with exact Q11 (m^3/s) and M11 (N*m)."""
    from scipy.stats import qmc

    from hillchart.synthetic.bulb import BLADE_RANGE_DEG, GUIDE_VANE_RANGE_DEG, SyntheticBulb

    turbine = turbine or SyntheticBulb()
    opening_range = GUIDE_VANE_RANGE_DEG if opening_range is None else opening_range
    lo = np.array([n11_range[0], opening_range[0], BLADE_RANGE_DEG[0]])
    hi = np.array([n11_range[1], opening_range[1], BLADE_RANGE_DEG[1]])
    corners = np.array([[lo[0] if i & 1 == 0 else hi[0], lo[1] if i & 2 == 0 else hi[1],
                         lo[2] if i & 4 == 0 else hi[2]] for i in range(8)])  # the fitted box = the chart's ranges
    x = np.vstack([corners, qmc.scale(qmc.LatinHypercube(d=3, seed=np.random.default_rng(seed)).random(n_points - 8),
                                      lo, hi)])
    n11, gv, blade = x.T
    return {"n11": n11, "opening": gv, "blade_angle": blade, "q11": turbine.q11(n11, gv, blade),
            "m11": turbine.m11(n11, gv, blade)}


def train_double_regulated_nets(samples: dict, *, hidden: int = 15, restarts: int = 3, seed: int = 0,
                                split=(0.70, 0.15, 0.15)) -> DoubleRegulatedNets:
    """Q11 and M11 nets (3-H-1 logsig, Levenberg-Marquardt, as :class:`FCCMNet`) from chart samples with keys
    n11, opening, blade_angle, q11, m11; the flow net uses ``seed``, the torque net ``seed + 1``."""
    X = np.column_stack([np.asarray(samples[k], dtype=float) for k in NET3_INPUTS])
    nets, record = {}, {"hidden": hidden, "restarts": restarts, "split": list(split), "n_samples": int(len(X))}
    for offset, (key, out) in enumerate((("flow", "q11"), ("torque", "m11"))):
        est = FCCMNet(hidden=hidden, restarts=restarts, seed=seed + offset, split=split).fit(
            X, np.asarray(samples[out], dtype=float), input_names=NET3_INPUTS, output_names=(out,))
        nets[key] = est.weights_
        record[key] = est.training_record()
    return DoubleRegulatedNets(flow=nets["flow"], torque=nets["torque"], opening_unit="deg", training=record)


#: How the shipped bulb nets (``data_synthetic/bulb/nets.json``) are made: samples of the synthetic bulb's unit
#: characteristic over the range a load rejection of the example plant visits (n11 up to runaway, guide vanes down
#: to 0.2 deg above closure), plus samples at the closed vane (Q11 = 0: the extension to zero opening, without which
#: the nets leak a little flow at closure that pumps the water hammer), and the net size.
SHIPPED_BULB_NETS = {"n_points": 2000, "n_closed": 300, "seed": 0, "n11_range": (100.0, 300.0),
                     "opening_range": (35.2, 78.0), "hidden": 30, "restarts": 2}


def bulb_closed_vane_samples(turbine=None, *, n_points: int = 300, seed: int = 0, n11_range=(100.0, 300.0)) -> dict:
    """Samples of the synthetic bulb at the closed guide vane (1e-6 deg above the angle at which the vanes touch:
    Q11 ~ 0, M11 the disc friction), over a seeded uniform draw of n11 (r/min) and blade angle (deg)."""
    from hillchart.synthetic.bulb import BLADE_RANGE_DEG, SyntheticBulb

    turbine = turbine or SyntheticBulb()
    rng = np.random.default_rng([seed, 2])
    n11 = rng.uniform(n11_range[0], n11_range[1], n_points)
    blade = rng.uniform(BLADE_RANGE_DEG[0], BLADE_RANGE_DEG[1], n_points)
    gv = np.full(n_points, turbine.params.guide_vane_closed_deg + 1e-6)
    return {"n11": n11, "opening": gv, "blade_angle": blade, "q11": turbine.q11(n11, gv, blade),
            "m11": turbine.m11(n11, gv, blade)}


def write_bulb_nets(out_dir) -> Path:
    """Train and write the shipped three-input nets of the synthetic bulb (:data:`SHIPPED_BULB_NETS`) to
    ``out_dir/nets.json``; the same settings give the same nets (seeded)."""
    cfg = SHIPPED_BULB_NETS
    chart = bulb_chart_samples(n_points=cfg["n_points"], seed=cfg["seed"], n11_range=cfg["n11_range"],
                               opening_range=cfg["opening_range"])
    closed = bulb_closed_vane_samples(n_points=cfg["n_closed"], seed=cfg["seed"], n11_range=cfg["n11_range"])
    samples = {k: np.concatenate([chart[k], closed[k]]) for k in chart}
    nets = train_double_regulated_nets(samples, hidden=cfg["hidden"], restarts=cfg["restarts"], seed=cfg["seed"])
    # below the sampled box (0.2 deg above the closed vane) the physical bulb model answers, fitted to the samples as
    # it is to a user's table (hillchart.extension.bulb_model): at the closed vane, where a rejection spends most of
    # its run, the loop then evaluates the model and not the two 3-30-1 nets
    from hillchart.extension.bulb_model import fit_bulb_model
    from hillchart.synthetic.bulb import SyntheticBulb

    model = fit_bulb_model(chart["n11"], chart["opening"], chart["blade_angle"], chart["q11"], chart["m11"],
                           opening_closed=SyntheticBulb().params.guide_vane_closed_deg, seed=cfg["seed"],
                           source="the shipped bulb samples")
    nets.silent_model = BulbSilentModel.from_fitted(model, cfg["opening_range"][0])
    nets.training["boundary_model"] = model.to_dict()
    nets.training["source"] = ("samples of the synthetic bulb's unit characteristic (hillchart.synthetic.bulb): "
                               f"{cfg['n_points']} scattered, {cfg['n_closed']} at the closed vane, seed {cfg['seed']}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    return nets.save(out / "nets.json")


def table_unit_samples(table, *, opening_closed: float | None = None, zero_opening_points: int = 200,
                       seed: int = 0, extension: bool = True) -> tuple[dict, list[str], object]:
    """Unit samples (n11, opening, blade_angle, q11, m11, origin) of a double-regulated test table
    (:class:`hillchart.fccm.table.TestTable` with ``guide_vane_deg``, ``n11_rpm``, ``q11_m3_s``, ``efficiency`` and
    ``blade_angle_deg``), the notes on what was assumed, and the fitted bulb model (None without the extension).

    * M11 from the efficiency, eq. (5) of the BP hill-chart paper (``M11 = rho g Q11 eta / omega11``).
    * A table without ``blade_angle_deg`` is a fixed-blade (propeller) unit: ``blade_angle_deg`` of the table's
      ``table.toml`` is not known, so the angle is taken as 0 deg (a note says so); the nets then do not depend on it.
    * ``extension`` (default): the physical bulb model fitted to the table
      (:func:`hillchart.extension.bulb_model.fit_bulb_model`, with ``opening_closed`` when given, else the closed
      angle fitted) gives the samples where the table is silent
      (:func:`hillchart.extension.bulb_model.extension_samples`): the closed vane (Q11 = 0, M11 = -K N11^2, eqs.
      (6) and (8) of paper 004), runaway, zero speed and the region between them and the table. Raises
      :class:`InputError` when the model cannot represent the table.
    * Without the extension, with ``opening_closed`` (the guide-vane angle at which the vanes touch):
      ``zero_opening_points`` samples with Q11 = 0 and M11 = 0 over the table's N11 and blade-angle range.
    """
    from hillchart.characteristics import unit_torque_from_efficiency

    from hillchart.fccm.on_cam import is_on_cam_table

    if is_on_cam_table(table):
        raise InputError("the table has blade_angle_deg but no guide_vane_deg: an on-cam chart, whose nets are "
                         "two-input over the cam position (hillchart.fccm.on_cam.on_cam_unit_samples; hillsim fccm "
                         "--simulator-nets does this by itself)")
    notes = []
    n11 = np.asarray(table.column("n11_rpm"), float)
    q11 = np.asarray(table.column("q11_m3_s"), float)
    opening = np.asarray(table.column("guide_vane_deg"), float)
    eta = np.asarray(table.column("efficiency"), float)
    if "blade_angle_deg" in table.columns:
        blade = np.asarray(table.column("blade_angle_deg"), float)
    else:
        blade = np.zeros_like(n11)
        notes.append("the table has no blade_angle_deg column: a fixed-blade (propeller) unit, blade angle taken as "
                     "0 deg (use combinator.relation = \"off\", fixed_angle_deg = 0 in the plant)")
    ok = np.isfinite(n11) & np.isfinite(q11) & np.isfinite(eta) & (n11 > 0)
    if not ok.all():
        notes.append(f"{int((~ok).sum())} rows without n11, Q11 or efficiency left out")
    n11, q11, opening, eta, blade = n11[ok], q11[ok], opening[ok], eta[ok], blade[ok]
    m11 = unit_torque_from_efficiency(q11, n11, eta)  # eq. (5) of paper 004
    samples = {"n11": n11, "opening": opening, "blade_angle": blade, "q11": q11, "m11": np.asarray(m11, float),
               "origin": np.full(n11.size, "measured")}
    if opening_closed is not None and not opening_closed < opening.min():
        raise InputError(f"the closed guide-vane angle {opening_closed!r} must be below the table's smallest "
                         f"guide_vane_deg {opening.min()!r}")
    model = None
    if extension:
        samples, note, model = extend_unit_samples(samples, opening_closed=opening_closed, seed=seed,
                                                   source=f"the table {table.info.name!r}")
        notes.append(note)
    elif opening_closed is not None:
        rng = np.random.default_rng([seed, 3])
        k = int(zero_opening_points)
        zero = {"n11": rng.uniform(n11.min(), n11.max(), k), "opening": np.full(k, float(opening_closed)),
                "blade_angle": rng.uniform(blade.min(), blade.max(), k) if np.ptp(blade) > 0 else np.full(k, blade[0]),
                "q11": np.zeros(k), "m11": np.zeros(k), "origin": np.full(k, "zero-opening")}
        samples = {key: np.concatenate([samples[key], zero[key]]) for key in samples}
        notes.append(f"extended to the closed vane ({opening_closed:g} deg): {k} samples with Q11 = 0, M11 = 0")
    return samples, notes, model


def extend_unit_samples(samples: dict, *, opening_closed: float | None = None, seed: int = 0,
                        source: str = "the table") -> tuple[dict, str, object]:
    """Measured unit samples (dict of n11, opening, blade_angle, q11, m11, origin "measured") plus the samples of the
    physical bulb model fitted to them where they are silent (:func:`hillchart.extension.bulb_model.fit_bulb_model`,
    :func:`hillchart.extension.bulb_model.extension_samples`), the note that says so, and the model: the extension of
    :func:`table_unit_samples`. Raises :class:`InputError` when the model cannot represent the samples."""
    from hillchart.extension.bulb_model import extension_samples, fit_bulb_model

    n11, opening, blade = (np.asarray(samples[k], float) for k in NET3_INPUTS)
    model = fit_bulb_model(n11, opening, blade, samples["q11"], samples["m11"], opening_closed=opening_closed,
                           seed=seed, source=source)
    extra = extension_samples(model, n11, opening, blade)
    out = {key: np.concatenate([np.asarray(samples[key]), extra[key]]) for key in extra}
    counts = {o: int(np.sum(extra["origin"] == o)) for o in ("zero-opening", "runaway", "zero-speed", "silent-region")}
    closed_text = (f"fitted closed vane {model.opening_closed:.4g} deg" if model.closed_fitted
                   else f"closed vane {model.opening_closed:g} deg")
    note = (f"extended by the physical bulb model (fits the table to Q11 RMS {model.q11_rms_pct:.2g} %, M11 RMS "
            f"{model.m11_rms_pct:.2g} % of the largest measured value; {closed_text}, K = "
            f"{model.k_zero_opening:.3g} N*m/(r/min)^2): " + ", ".join(f"{n} {o}" for o, n in counts.items())
            + " samples")
    if model.closed_at_limit:
        note += (f"; {model.closed_limit_text}, and below the smallest tested angle the answer rests on it: give it "
                 "with --closed-opening (opening_closed in Python), the angle at which the vanes touch, from the "
                 "guide-vane drawing, if it is known")
    return out, note, model


def train_table_nets(samples: dict, *, hidden: int = 15, restarts: int = 3, seed: int = 0, members: int = 5,
                     split=(0.70, 0.15, 0.15), model=None) -> tuple["DoubleRegulatedNets", dict]:
    """Three-input nets from ``samples`` (:func:`table_unit_samples`) with an ensemble of ``members`` nets (seeds
    ``seed``, ``seed + 2``, ...; the first is the point nets) and the plausibility checks: on a grid over the
    samples' box, the share of points where Q11 falls as the guide vanes open (dQ11/da < 0), where the efficiency
    exceeds 1 (where Q11 is above 5 % of its largest value), and the ensemble's spread (5-95 % of Q11 and M11, as
    % of their ranges). A constant input (a fixed-blade table) is widened by 1 on either side (copies of the samples
    at -1, 0, +1) so the net's scaling is defined; the nets do not depend on it.

    With ``model`` (the fitted bulb model :func:`table_unit_samples` returns), the nets learn the residual to the
    model (what it misses at the measured samples; at its samples between the table and the boundaries that residual
    carried from the table and faded out, :func:`hillchart.extension.residual.continued_residual`; zero at the
    boundaries: the closed vane, runaway, zero speed), and the model is stored with
    them (:class:`BulbSilentModel`, ``residual``): the characteristics are the model's plus the nets' residual. Below
    the table's smallest guide-vane angle the hypotheses weighed by the table's own held-out angles answer
    (:func:`hillchart.fccm.evidence.table_evidence`, recorded in ``training["extrapolation"]``); the point nets read
    their weighed answer, each member stands at its place in their band
    (:func:`hillchart.extension.band.member_positions`, seeded by ``seed``), as the Francis nets do. The members
    differ otherwise by their seeds (splits and initialisations).

    Returns
    -------
    nets : DoubleRegulatedNets
    report : dict
        ``plausibility`` figures and ``warnings`` (text that says what to check).
    """
    X = {k: np.asarray(samples[k], float) for k in NET3_INPUTS}
    arrays = ("n11", "opening", "blade_angle", "q11", "m11")
    constant = [k for k in NET3_INPUTS if np.ptp(X[k]) == 0]

    def widened(member_samples):
        # a constant input: copies at -1, 0 and +1 so that the scaling is defined, the slope 0, and the net is
        # trained at the constant itself (with copies at +-1 alone a 3-6-1 net interpolated Q11 2.5 x off at 0)
        fitted = {k: np.asarray(member_samples[k], float) for k in arrays}
        if constant:
            size = fitted["n11"].size
            fitted = {k: np.concatenate([fitted[k]] * 3) for k in arrays}
            for k in constant:
                fitted[k] = fitted[k] + np.repeat([-1.0, 0.0, 1.0], size)
        return fitted

    origin = np.asarray(samples.get("origin", np.full(X["n11"].size, "measured")))
    measured = origin == "measured"
    fitted = samples
    if model is not None:  # what the model misses: the table's, carried into the region between it and the bounds
        x = np.column_stack([X[k] for k in NET3_INPUTS])
        fitted = {**samples, "q11": np.asarray(samples["q11"], float) - model.q11(*x.T),
                  "m11": np.asarray(samples["m11"], float) - model.m11(*x.T)}
        silent = origin == "silent-region"
        if silent.any() and measured.sum() > 2:
            for key in ("q11", "m11"):
                fitted[key][silent] = continued_residual(x[measured], fitted[key][measured], x[silent])
    count = max(1, members)
    ensemble = [train_double_regulated_nets(widened(fitted), hidden=hidden, restarts=restarts, seed=seed + 2 * i,
                                            split=split) for i in range(count)]
    member_silent = [None] * count
    evidence = None
    if model is not None:  # the nets are the residual to the model; below the table the weighed hypotheses answer
        from hillchart.extension.band import member_positions
        from hillchart.fccm.evidence import angle_step, low_band, table_evidence

        evidence = table_evidence({k: np.asarray(samples[k], float)[measured] for k in arrays}, model, seed=seed)
        # the point nets' own miss at the smallest angle, where a run takes every hypothesis' y_low from them
        a_low = float(X["opening"][measured].min())
        at_low = measured & (X["opening"] == a_low)
        x_low = [X[k][at_low] for k in NET3_INPUTS]
        low = low_band(model.q11(*x_low) + ensemble[0].q11(*x_low), model.m11(*x_low) + ensemble[0].m11(*x_low),
                       np.asarray(samples["q11"], float)[at_low], np.asarray(samples["m11"], float)[at_low],
                       evidence.m11_scale)
        point = BulbSilentModel.from_fitted(model, a_low, residual=True,
                                            extrapolation=BulbExtrapolation.of_evidence(evidence, low=low),
                                            step=angle_step(*(X[k][measured] for k in NET3_INPUTS)))
        member_silent = [point.at(float(u)) for u in member_positions(count, seed)] if count > 1 else [point]
        for member, silent in zip(ensemble, member_silent):
            member.silent_model = silent
    nets = ensemble[0]
    lo = np.array([X[k].min() for k in NET3_INPUTS])
    hi = np.array([X[k].max() for k in NET3_INPUTS])
    axes = [np.linspace(lo[j], hi[j], 12) for j in range(3)]
    g = np.meshgrid(*axes, indexing="ij")
    n11, a, phi = (v.ravel() for v in g)
    q = nets.q11(n11, a, phi)
    dq_da = nets.q11_grad(n11, a, phi)[1]
    eta = nets.efficiency(n11, a, phi)
    q_all = np.array([m.q11(n11, a, phi) for m in ensemble])
    m_all = np.array([m.m11(n11, a, phi) for m in ensemble])
    spread_q = float(np.median(np.percentile(q_all, 95, axis=0) - np.percentile(q_all, 5, axis=0))
                     / max(np.ptp(samples["q11"]), 1e-12))
    spread_m = float(np.median(np.percentile(m_all, 95, axis=0) - np.percentile(m_all, 5, axis=0))
                     / max(np.ptp(samples["m11"]), 1e-12))
    flowing = q > 0.05 * q.max()  # the efficiency of a near-zero flow is the ratio of two small numbers
    eta = np.where(flowing, eta, np.nan)
    report = {"plausibility": {"share_dq11_da_negative": float(np.mean(dq_da < 0)),
                               "share_efficiency_above_1": float(np.mean(np.nan_to_num(eta) > 1.0)),
                               "max_efficiency": float(np.nanmax(eta)), "q11_min": float(q.min()),
                               "ensemble_members": len(ensemble),
                               "ensemble_spread_q11_pct": 100.0 * spread_q,
                               "ensemble_spread_m11_pct": 100.0 * spread_m},
              "warnings": []}
    p = report["plausibility"]
    if p["share_dq11_da_negative"] > 0.05:
        report["warnings"].append(f"Q11 falls as the guide vanes open on {100 * p['share_dq11_da_negative']:.0f} % of "
                                  "the table's box: the nets fit noise or the table is thin there; check the table, "
                                  "fewer hidden neurons (--hidden)")
    if p["share_efficiency_above_1"] > 0:
        report["warnings"].append(f"the nets' efficiency exceeds 1 on {100 * p['share_efficiency_above_1']:.1f} % of "
                                  f"the table's box (max {p['max_efficiency']:.3f}): implausible; check the table's "
                                  "efficiency column (a fraction) and the extension")
    nets.training["plausibility"] = p
    # the box of the table itself (the nets' box includes the extension): the combinator's cam is searched over it
    nets.training["measured_box"] = {k: [float(X[k][measured].min()), float(X[k][measured].max())]
                                     for k in NET3_INPUTS}
    nets.training["ensemble_seeds"] = [seed + 2 * i for i in range(len(ensemble))]
    if len(ensemble) > 1:  # kept for the bands of the guarantee figures (hillsim run --uncertainty)
        nets.ensemble = [(m.flow, m.torque, m.silent_model) for m in ensemble]
    if evidence is not None:  # the point nets read the weighed hypotheses themselves, their members the band
        nets.silent_model = nets.silent_model.at(0.0)
        nets.training["extrapolation"] = evidence.to_dict()
    return nets, report


__all__ = ["NET3_INPUTS", "BLEND_START_FRACTION", "SILENT_KIND", "NO_BLEND", "WEIGHED", "SHIPPED_BULB_NETS",
           "packed_net3", "net3_point", "weighed_point", "blended_point", "blended_value", "BulbSilentModel",
           "DoubleRegulatedNets", "load_double_regulated_nets", "on_cam_relation", "plot_on_cam",
           "bulb_chart_samples", "train_double_regulated_nets", "bulb_closed_vane_samples", "write_bulb_nets",
           "table_unit_samples", "extend_unit_samples", "train_table_nets"]
