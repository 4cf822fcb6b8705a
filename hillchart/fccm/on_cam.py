"""Nets for the simulator from an on-cam Kaplan chart: a table with the blade angle but no guide-vane angle.

Every point of such a chart (e.g. a Kaplan hill chart drawn with one line per blade angle) lies on the combinator's
cam: the guide vanes stand where the cam puts them for that blade angle. The chart cannot tell the vanes' effect
from the blades', so it cannot feed the three-input nets Q11(N11, a, phi) of
:mod:`hillchart.fccm.double_regulated`. What it does determine is the unit on its cam: two-input characteristics
Q11(N11, c), M11(N11, c) over the **cam position** c, the chart's blade angle counted from the cam position at which
the flow stops (``c = phi - phi_closed``, deg). The simulator runs them as a single-regulated unit whose one servo
drives the cam: vanes and blades move together. What that cannot represent is the blades lagging the cam on their
slower servo (the overspeed of a real rejection depends on it); :data:`ON_CAM_WARNING` says so and how to fix it.

Below the lowest blade-angle line the cam position stands for the vanes closing with the blades at their stop; the
chart says nothing there. The samples are extended to the closed cam (Q11 = 0, M11 = 0, as the closed-vane extension
of :func:`hillchart.fccm.double_regulated.table_unit_samples`), and the nets interpolate between it and the lowest
line.
"""

from __future__ import annotations

import numpy as np

from hillchart.errors import InputError

#: Inputs of the two-input on-cam nets (the simulator's two-input nets.json: N11 and the opening, here the cam).
ON_CAM_INPUTS = ("n11", "opening")

#: The closed-cam samples reach this multiple of the chart's largest N11 (r/min).
CLOSED_N11_FACTOR = 2.0

#: Cam positions (fractions of the lowest line's) of the assumed samples between the closed cam and the lowest line.
SILENT_FRACTIONS = (0.25, 0.5, 0.75)

#: What an on-cam chart cannot represent and how to fix it (printed by ``hillsim fccm --simulator-nets``, written
#: into nets.json's training record).
ON_CAM_WARNING = ("an on-cam chart (blade_angle_deg without guide_vane_deg): the nets follow the cam, so the unit "
                  "is simulated with vanes and blades moving together on one servo; the blades' lag behind the cam "
                  "(their slower servo, which raises the overspeed of a load rejection) cannot be represented. "
                  "To simulate it, give a table with guide_vane_deg and blade_angle_deg (off-cam points) for the "
                  "three-input nets")


def is_on_cam_table(table) -> bool:
    """True for a test table with ``blade_angle_deg`` and no ``guide_vane_deg`` column (an on-cam chart)."""
    return "blade_angle_deg" in table.columns and "guide_vane_deg" not in table.columns


def closed_cam_angle(blade_deg, n11, q11) -> float:
    """The blade angle (deg, on the cam's coordinate) at which Q11 reaches zero: Q11 extrapolated linearly in the
    blade angle from the two lowest blade-angle lines, at each N11 of the lowest line inside the second line's N11
    range (the second line interpolated linearly in N11), the median over those N11.

    Raises
    ------
    InputError
        Fewer than two blade-angle lines, lines that do not overlap in N11, or Q11 not rising with the blade angle.
    """
    blade, n11, q11 = (np.asarray(v, float) for v in (blade_deg, n11, q11))
    lines = np.unique(blade)
    if lines.size < 2:
        raise InputError(f"blade_angle_deg: an on-cam table needs at least two blade-angle lines to place the closed "
                         f"cam, got {lines.tolist()}; give --closed-opening (the cam's blade angle at zero flow)")
    lo, hi = (blade == lines[0]), (blade == lines[1])
    order = np.argsort(n11[hi])
    n_hi, q_hi = n11[hi][order], q11[hi][order]
    inside = (n11[lo] >= n_hi[0]) & (n11[lo] <= n_hi[-1])
    if not inside.any():
        raise InputError(f"blade_angle_deg: the two lowest lines ({lines[0]:g}, {lines[1]:g} deg) share no n11 range; "
                         f"give --closed-opening (the cam's blade angle at zero flow)")
    q0 = q11[lo][inside]
    q1 = np.interp(n11[lo][inside], n_hi, q_hi)
    if not np.all(q1 > q0):
        raise InputError(f"q11_m3_s does not rise from the blade-angle line {lines[0]:g} deg to {lines[1]:g} deg at "
                         f"every common n11: the closed cam cannot be extrapolated; give --closed-opening")
    return float(np.median(lines[0] - q0 * (lines[1] - lines[0]) / (q1 - q0)))


def on_cam_unit_samples(table, *, closed_angle_deg: float | None = None, zero_opening_points: int = 200,
                        seed: int = 0) -> tuple[dict, list[str], float]:
    """Unit samples (n11, opening = cam position c = phi - phi_closed in deg, q11, m11; ``measured`` marks the
    chart's own points) of an on-cam table
    (:func:`is_on_cam_table`), the notes on what was assumed, and phi_closed (deg).

    * M11 from the efficiency, eq. (5) of the BP hill-chart paper (``M11 = rho g Q11 eta / omega11``).
    * phi_closed: ``closed_angle_deg``, or :func:`closed_cam_angle` (a note says so).
    * Between the closed cam and the lowest line, at the lowest line's N11: Q11 and the efficiency linear in c
      down to zero (at :data:`SILENT_FRACTIONS` of the lowest line's c; assumed, a note says so).
    * The extension to the closed cam: ``zero_opening_points`` samples at c = 0 with Q11 = 0, M11 = 0 over N11
      from 0 to :data:`CLOSED_N11_FACTOR` times the table's largest (seeded).
    """
    from hillchart.characteristics import unit_torque_from_efficiency

    if not is_on_cam_table(table):
        raise InputError(f"an on-cam table has blade_angle_deg and no guide_vane_deg, got columns "
                         f"{', '.join(table.columns)}")
    n11 = np.asarray(table.column("n11_rpm"), float)
    q11 = np.asarray(table.column("q11_m3_s"), float)
    eta = np.asarray(table.column("efficiency"), float)
    blade = np.asarray(table.column("blade_angle_deg"), float)
    notes = [ON_CAM_WARNING]
    ok = np.isfinite(n11) & np.isfinite(q11) & np.isfinite(eta) & np.isfinite(blade) & (n11 > 0)
    if not ok.all():
        notes.append(f"{int((~ok).sum())} rows without n11, Q11, efficiency or blade angle left out")
    n11, q11, eta, blade = n11[ok], q11[ok], eta[ok], blade[ok]
    if closed_angle_deg is None:
        closed = closed_cam_angle(blade, n11, q11)
        notes.append(f"closed cam at blade angle {closed:.2f} deg: Q11 extrapolated linearly to zero from the two "
                     f"lowest blade-angle lines (give --closed-opening to set it)")
    else:
        closed = float(closed_angle_deg)
        if not closed < blade.min():
            raise InputError(f"--closed-opening {closed!r} (the cam's blade angle at zero flow) must be below the "
                             f"table's smallest blade_angle_deg {blade.min()!r}")
        notes.append(f"closed cam at blade angle {closed:g} deg (given)")
    m11 = np.asarray(unit_torque_from_efficiency(q11, n11, eta), float)  # eq. (5) of paper 004
    # below the lowest line (vanes closing, blades at their stop) the chart says nothing: at the lowest line's
    # points, Q11 and the efficiency taken linear in the cam position down to zero at the closed cam (a stated
    # assumption: flow and efficiency both vanish at closure; M11 again from eq. (5))
    low = blade == blade.min()
    frac = np.repeat(SILENT_FRACTIONS, int(low.sum()))
    q_s = frac * np.tile(q11[low], len(SILENT_FRACTIONS))
    n_s = np.tile(n11[low], len(SILENT_FRACTIONS))
    m_s = np.asarray(unit_torque_from_efficiency(q_s, n_s, frac * np.tile(eta[low], len(SILENT_FRACTIONS))), float)
    c_s = frac * (blade.min() - closed)
    notes.append(f"below the lowest blade-angle line ({blade.min():g} deg): {q_s.size} samples with Q11 and the "
                 f"efficiency linear in the cam position down to zero at the closed cam (assumed, not charted)")
    k = int(zero_opening_points)
    rng = np.random.default_rng([seed, 3])
    # the closed cam passes no water at any unit speed: the samples reach twice the chart's largest N11, so that a
    # closing transient whose head falls (N11 = n D / sqrt(H) rises) meets no flow the nets invent past the chart
    samples = {"n11": np.concatenate([n11, n_s, rng.uniform(0.0, CLOSED_N11_FACTOR * n11.max(), k)]),
               "opening": np.concatenate([blade - closed, c_s, np.zeros(k)]),
               "q11": np.concatenate([q11, q_s, np.zeros(k)]), "m11": np.concatenate([m11, m_s, np.zeros(k)]),
               "measured": np.concatenate([np.ones(n11.size, bool), np.zeros(q_s.size + k, bool)])}
    notes.append(f"opening = cam position c = blade angle - ({closed:.2f} deg), {blade.max() - closed:.2f} "
                 f"deg at the largest blade angle (turbine.opening_max); extended to the closed cam: {k} samples "
                 f"with Q11 = 0, M11 = 0 over N11 0-{CLOSED_N11_FACTOR * n11.max():.4g} r/min")
    return samples, notes, closed


def _net_weights(fccm_weights):
    from hillchart.nets.weights import NetWeights

    w = fccm_weights
    return NetWeights(x_min=w.x_min, x_max=w.x_max, y_min=float(w.y_min[0]), y_max=float(w.y_max[0]), W1=w.W1,
                      b1=w.b1, W2=w.W2[0], b2=float(w.b2[0]))


def train_on_cam_nets(samples: dict, *, hidden: int = 8, restarts: int = 3, seed: int = 0,
                      members: int = 5, split=(0.70, 0.15, 0.15)):
    """Two-input nets Q11(N11, c), M11(N11, c) (:class:`hillchart.nets.hill_nets.HillNets`, opening unit
    ``"deg (cam)"``) from :func:`on_cam_unit_samples`, trained as the three-input ones (2-H-1 logsig,
    Levenberg-Marquardt, :class:`hillchart.fccm.net.FCCMNet`; the flow net with ``seed``, the torque net
    ``seed + 1``), an ensemble of ``members`` (seeds ``seed``, ``seed + 2``, ...; the first is the point nets), the
    digitized region (convex hull of the samples marked ``measured``: the chart's points) and the plausibility
    checks on a grid over the samples' box: Q11 falling as the cam opens, efficiency above 1 where Q11 is above 5 %
    of its largest value, the ensemble's spread (5-95 % of Q11 and M11, as % of their ranges).

    Returns
    -------
    nets : HillNets
    report : dict
        ``plausibility`` figures and ``warnings``.
    """
    from scipy.spatial import ConvexHull

    from hillchart.fccm.net import FCCMNet
    from hillchart.nets.hill_nets import HillNets

    X = np.column_stack([np.asarray(samples[k], float) for k in ON_CAM_INPUTS])
    pairs = []
    for i in range(max(1, members)):
        pair = []
        for offset, out in enumerate(("q11", "m11")):
            est = FCCMNet(hidden=hidden, restarts=restarts, seed=seed + 2 * i + offset, split=split).fit(
                X, np.asarray(samples[out], float), input_names=ON_CAM_INPUTS, output_names=(out,))
            pair.append(_net_weights(est.weights_))
        pairs.append(tuple(pair))
    digitized = X[np.asarray(samples["measured"], bool)]
    region = digitized[ConvexHull(digitized).vertices]
    training = {"kind": "on-cam", "hidden": hidden, "restarts": restarts, "split": list(split),
                "n_samples": int(len(X)), "ensemble_seeds": [seed + 2 * i for i in range(len(pairs))]}
    nets = HillNets(flow=pairs[0][0], torque=pairs[0][1], opening_unit="deg (cam)", training=training,
                    ensemble=pairs if len(pairs) > 1 else None, digitized_region=region)
    lo, hi = X.min(axis=0), X.max(axis=0)
    n11, c = (v.ravel() for v in np.meshgrid(*(np.linspace(lo[j], hi[j], 20) for j in range(2)), indexing="ij"))
    q = nets.q11(n11, c)
    dq_dc = nets.q11_grad(n11, c)[1]
    eta = np.where(q > 0.05 * q.max(), nets.efficiency(n11, c), np.nan)  # near-zero flow: a ratio of small numbers
    q_all = np.array([f.evaluate(n11, c)[0] for f, _ in pairs])
    m_all = np.array([t.evaluate(n11, c)[0] for _, t in pairs])

    def spread(values, key):
        band = np.percentile(values, 95, axis=0) - np.percentile(values, 5, axis=0)
        return 100.0 * float(np.median(band) / max(np.ptp(samples[key]), 1e-12))

    p = {"share_dq11_dc_negative": float(np.mean(dq_dc < 0)),
         "share_efficiency_above_1": float(np.mean(np.nan_to_num(eta) > 1.0)), "max_efficiency": float(np.nanmax(eta)),
         "ensemble_members": len(pairs), "ensemble_spread_q11_pct": spread(q_all, "q11"),
         "ensemble_spread_m11_pct": spread(m_all, "m11")}
    warnings = [ON_CAM_WARNING]
    if p["share_dq11_dc_negative"] > 0.05:
        warnings.append(f"Q11 falls as the cam opens on {100 * p['share_dq11_dc_negative']:.0f} % of the table's box: "
                        "the nets fit noise or the table is thin there; check the table, fewer hidden neurons "
                        "(--hidden)")
    if p["share_efficiency_above_1"] > 0:
        warnings.append(f"the nets' efficiency exceeds 1 on {100 * p['share_efficiency_above_1']:.1f} % of the "
                        f"table's box (max {p['max_efficiency']:.3f}): implausible; check the table's efficiency "
                        "column (a fraction) and --closed-opening")
    nets.training["plausibility"] = p
    return nets, {"plausibility": p, "warnings": warnings}
