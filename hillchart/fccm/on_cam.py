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
line. How far that answer can be trusted is measured on the chart's own lines (:func:`on_cam_evidence`): its lowest
line, then its two lowest, are held out, the same answer is made from the lines left, and its misses give the band's
width below the lowest line, as for a Francis chart (:mod:`hillchart.extension.band`); each ensemble member's samples
there stand at their place in that band (:func:`train_on_cam_nets`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hillchart.errors import InputError

#: Inputs of the two-input on-cam nets (the simulator's two-input nets.json: N11 and the opening, here the cam).
ON_CAM_INPUTS = ("n11", "opening")

#: The closed-cam samples reach this multiple of the chart's largest N11 (r/min).
CLOSED_N11_FACTOR = 2.0

#: Cam positions (fractions of the lowest line's) of the assumed samples between the closed cam and the lowest line.
#: Every tenth: the ensemble members' samples stand at their places in the band (:func:`train_on_cam_nets`), and
#: their nets follow the band between the samples only where the samples are this close. With a quarter's spacing
#: the members' 5-95 % spread at 7/8 of the way to the closed cam was 0.62 of the band's high side on a smooth
#: chart (tests/hillchart/fccm/test_on_cam.py), and on the real Kaplan chart with its two lowest lines held out
#: 0.2-0.5 of the band's low side at the 16 deg line, 13 % of the way down, where the band's growth bends.
SILENT_FRACTIONS = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9)

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


#: The inner folds of :func:`on_cam_evidence`: the j lowest blade-angle lines held out, for each j here that leaves two
#: lines to place the closed cam.
HOLD_OUT = (1, 2)
#: Below the lowest line the efficiency is one of these, weighed by the chart's held-out lines
#: (:func:`on_cam_evidence`): ``held`` weight of the efficiency held at the lowest line's (:func:`silent_efficiency`).
EFFICIENCY_HYPOTHESES = {"efficiency linear to zero": 0.0, "efficiency held": 1.0}


def silent_efficiency(eta_low, t, held: float):
    """The efficiency below the lowest line at the cam fraction ``t = c / c_low`` of it, from the lowest line's
    ``eta_low``: the weighed blend of the two hypotheses of :data:`EFFICIENCY_HYPOTHESES`, linear in the cam down to
    zero at the closed cam (weight ``1 - held``) and held at the lowest line's (weight ``held``; M11 then linear in
    the cam, the straight-line baseline)."""
    return eta_low * ((1.0 - held) * t + held)


def line_answer(blade, n11, q11, efficiency, at_blade, at_n11, closed: float | None = None, held: float = 0.0):
    """What the samples below the lowest line of the chart (``blade``, ``n11``, ``q11``, ``efficiency``) say at
    (``at_blade``, ``at_n11``): Q11 linear in the cam position from the lowest line (interpolated at ``at_n11``) down
    to zero at the closed cam placed from the two lowest lines (:func:`closed_cam_angle`; ``closed``, deg, when it
    is given), the efficiency by :func:`silent_efficiency` (``held``: the weight of the efficiency held), M11 from
    them (eq. (5) of the BP hill-chart paper), as :func:`on_cam_unit_samples` samples it.

    Returns ``(q11, m11, distance, inside)``: ``distance`` is ``d = 1 - c / c_low`` below the lowest line (0 on it,
    1 at the closed cam), ``inside`` where ``at_n11`` lies within the lowest line's N11 range (outside it the line
    is not interpolated but held at its end).
    """
    from hillchart.characteristics import unit_torque_from_efficiency

    blade, n11, q11, efficiency = (np.asarray(v, float) for v in (blade, n11, q11, efficiency))
    closed = closed_cam_angle(blade, n11, q11) if closed is None else float(closed)
    low = blade == blade.min()
    order = np.argsort(n11[low])
    n_low = n11[low][order]
    t = (np.asarray(at_blade, float) - closed) / (blade.min() - closed)
    at_n11 = np.asarray(at_n11, float)
    q = np.interp(at_n11, n_low, q11[low][order]) * t
    eta = silent_efficiency(np.interp(at_n11, n_low, efficiency[low][order]), t, held)
    m = np.asarray(unit_torque_from_efficiency(q, at_n11, eta), float)  # eq. (5) of paper 004
    return q, m, 1.0 - t, (at_n11 >= n_low[0]) & (at_n11 <= n_low[-1])


@dataclass(frozen=True)
class OnCamEvidence:
    """How well an on-cam chart predicts its own lowest blade-angle lines (:func:`on_cam_evidence`), and the band it
    gives below its lowest line.

    Attributes
    ----------
    folds : tuple of dict
        Per inner fold: ``held_out_deg`` (the blade angles held out), ``points`` (held-out points inside the lowest
        kept line's N11 range), ``q11_mean_abs_pct`` and ``q11_worst_pct`` (Q11 error of :func:`line_answer`, % of
        Q11), ``m11_mean_abs_pct`` and ``m11_worst_pct`` (M11 error, % of the chart's M11 range).
    band_q11 : tuple of float
        ``(low, high)``: the half-widths of log Q11 per squared distance below the lowest line
        (:func:`hillchart.extension.band.band_sides`; :data:`hillchart.extension.band.NO_EVIDENCE_SCALE` on both
        sides without a fold).
    band_m11 : tuple of float
        The same for M11, in units of the chart's M11 range (``m11_scale``), closing as ``1 - d`` at the closed cam
        (where M11 is zero).
    m11_scale : float
        The chart's M11 range (N*m, unit torque).
    distance_cap : float
        The band grows as ``d^2`` up to this distance, the furthest the folds tested, and on at its slope there
        (:func:`hillchart.extension.band.band_square`, :data:`hillchart.extension.band.BEYOND_CAP`).
    weights : dict
        The weight of each of :data:`EFFICIENCY_HYPOTHESES` (equal without a fold).
    """

    folds: tuple
    band_q11: tuple
    band_m11: tuple
    m11_scale: float
    distance_cap: float
    weights: dict

    @property
    def efficiency_held(self) -> float:
        """The weight of the efficiency held at the lowest line's (:func:`silent_efficiency`)."""
        return sum(w * EFFICIENCY_HYPOTHESES[h] for h, w in self.weights.items())

    def _growth(self, distance) -> np.ndarray:
        from hillchart.extension.band import band_square

        return np.array([band_square(float(d), self.distance_cap, math.inf)[0] for d in np.ravel(distance)])

    def q11_widths(self, distance):
        """``(low, high)`` of the band at ``distance`` below the lowest line, as log-ratios of Q11 (>= 0)."""
        h = self._growth(distance)
        return self.band_q11[0] * h, self.band_q11[1] * h

    def m11_widths(self, distance):
        """``(low, high)`` of the band at ``distance`` below the lowest line, in M11 (N*m, >= 0): closing as ``1 - d``
        toward the closed cam where folds placed it and tested the torque there, not where there is no fold (the
        closed cam then placed from the two lowest lines alone, and the torque near it untested)."""
        d = np.ravel(np.asarray(distance, float))
        closing = np.clip(1.0 - d, 0.0, 1.0) if self.folds else 1.0
        h = self._growth(d) * closing * self.m11_scale
        return self.band_m11[0] * h, self.band_m11[1] * h

    def summary(self) -> str:
        """What ``hillsim fccm`` prints: the held-out misses and the band at half the lowest line's cam."""
        low, high = (float(v[0]) for v in self.q11_widths([0.5]))
        band = (f"efficiency below it weighed {', '.join(f'{h} {w:.2f}' for h, w in self.weights.items())}; the "
                f"band at half the lowest line's cam spans {100 * math.expm1(-low):+.0f} % to "
                f"{100 * math.expm1(high):+.0f} % of Q11")
        if not self.folds:
            return (f"below the lowest blade-angle line: no held-out evidence (it needs {HOLD_OUT[0] + 2} blade-angle "
                    f"lines or more, the lines left by a hold-out placing a closed cam): {band}; give more "
                    f"blade-angle lines")
        said = "; ".join(f"without {', '.join(f'{b:g}' for b in f['held_out_deg'])} deg the rest predicts it within "
                         f"{f['q11_mean_abs_pct']:.1f} % of Q11 and {f['m11_mean_abs_pct']:.1f} % of the M11 range "
                         f"(mean; worst {f['q11_worst_pct']:+.1f} % and {f['m11_worst_pct']:+.1f} %, {f['points']} "
                         f"points)" for f in self.folds)
        return f"below the lowest blade-angle line: {said}; {band}"

    def to_dict(self) -> dict:
        return {"folds": [dict(f) for f in self.folds], "band_log_q11": list(self.band_q11),
                "band_m11_of_range": list(self.band_m11), "m11_scale": self.m11_scale,
                "distance_cap": self.distance_cap, "efficiency_weights": dict(self.weights),
                "summary": self.summary()}


def on_cam_evidence(blade, n11, q11, efficiency, closed: float | None = None) -> OnCamEvidence:
    """The chart's evidence below its lowest blade-angle line: for each j of :data:`HOLD_OUT` (while two lines are
    left), the j lowest lines held out and predicted by :func:`line_answer` from the lines left; the misses at the
    held-out points inside the lowest kept line's N11 range (log-ratios of Q11; M11 as a share of the chart's M11
    range), over the squared distance, give the band (:func:`hillchart.extension.band.band_sides`: split-conformal,
    the held-out lines its units of evidence, neither side under half the other,
    :data:`hillchart.extension.band.MIN_SIDE_FRACTION_BELOW`, and both as wide as the wider where the folds
    calibrated on disagree on the side of the error or are one fold; M11's closing as ``1 - d``, as a Francis
    chart's does, where there is a fold: :meth:`OnCamEvidence.m11_widths`). A fold whose lines the closed cam
    cannot be placed from is left out (``closed``: the closed cam given, deg, held in every fold); with none the
    band is :data:`hillchart.extension.band.NO_EVIDENCE_SCALE` wide and the summary says to give more lines."""
    from hillchart.characteristics import unit_torque_from_efficiency
    from hillchart.extension.band import (MIN_SIDE_FRACTION_BELOW, NO_EVIDENCE_CAP, NO_EVIDENCE_SCALE, band_sides,
                                          log_ratio)

    blade, n11, q11, efficiency = (np.asarray(v, float) for v in (blade, n11, q11, efficiency))
    m11 = np.asarray(unit_torque_from_efficiency(q11, n11, efficiency), float)  # eq. (5) of paper 004
    scale = max(float(np.ptp(m11)), 1e-12)
    lines = np.unique(blade)
    folds, q_res, m_res, distance, held, fold_of = [], [], {h: [] for h in EFFICIENCY_HYPOTHESES}, [], 0, []
    for j in HOLD_OUT:
        if lines.size - j < 2:
            break
        out = blade < lines[j]
        try:  # the fold's closed cam, placed once for both efficiencies
            fold_closed = closed_cam_angle(blade[~out], n11[~out], q11[~out]) if closed is None else closed
        except InputError:  # the lines left do not place a closed cam: no evidence from this fold
            continue
        answers = {h: line_answer(blade[~out], n11[~out], q11[~out], efficiency[~out], blade[out], n11[out],
                                  fold_closed, w) for h, w in EFFICIENCY_HYPOTHESES.items()}
        q, _, d, inside = next(iter(answers.values()))
        if not inside.any():
            continue
        q_true, m_true = q11[out][inside], m11[out][inside]
        q_res.append(log_ratio(q[inside], q_true, 1e-9))
        for h, answer in answers.items():
            m_res[h].append((answer[1][inside] - m_true) / scale)
        distance.append(d[inside])
        fold_of.append(np.full(int(inside.sum()), j))
        held += j
        folds.append({"held_out_deg": [float(b) for b in lines[:j]], "points": int(inside.sum()),
                      "q11_error": q[inside] / q_true - 1.0})
    if not folds:
        wide = (NO_EVIDENCE_SCALE, NO_EVIDENCE_SCALE)
        equal = {h: 1.0 / len(EFFICIENCY_HYPOTHESES) for h in EFFICIENCY_HYPOTHESES}
        return OnCamEvidence(folds=(), band_q11=wide, band_m11=wide, m11_scale=scale,
                             distance_cap=NO_EVIDENCE_CAP, weights=equal)
    distance = np.concatenate(distance)
    # the efficiency's hypotheses weighed by their held-out likelihood, the held-out lines the units of evidence
    # (pseudo-BMA over errors divided by d^2, as a Francis chart's hypotheses: hillchart.extension.hypotheses.weigh)
    scores = {h: np.concatenate(r) / np.maximum(distance, 1e-9) ** 2 for h, r in m_res.items()}
    mse = {h: max(float(np.mean(v ** 2)), 1e-300) for h, v in scores.items()}
    best = min(mse.values())
    log_w = {h: -0.5 * held * math.log(v / best) for h, v in mse.items()}
    total = sum(math.exp(v) for v in log_w.values())
    weights = {h: math.exp(v) / total for h, v in log_w.items()}
    blend = sum(weights[h] * np.concatenate(m_res[h]) for h in m_res)
    start = 0
    for fold in folds:  # each fold's errors under the weighed efficiency
        n = fold["points"]
        q_err, m_err = fold.pop("q11_error"), blend[start:start + n]
        start += n
        fold.update({"q11_mean_abs_pct": 100.0 * float(np.mean(np.abs(q_err))),
                     "q11_worst_pct": 100.0 * float(q_err[np.argmax(np.abs(q_err))]),
                     "m11_mean_abs_pct": 100.0 * float(np.mean(np.abs(m_err))),
                     "m11_worst_pct": 100.0 * float(m_err[np.argmax(np.abs(m_err))])})
    fold_of = np.concatenate(fold_of)
    band_q = band_sides(np.concatenate(q_res), distance, held, min_side_fraction=MIN_SIDE_FRACTION_BELOW,
                        folds=fold_of)
    band_m = band_sides(blend, distance, held, shape=np.maximum(1.0 - distance, 1e-9),
                        min_side_fraction=MIN_SIDE_FRACTION_BELOW, folds=fold_of)
    return OnCamEvidence(folds=tuple(folds), band_q11=tuple(float(v) for v in band_q),
                         band_m11=tuple(float(v) for v in band_m), m11_scale=scale,
                         distance_cap=min(1.0, float(distance.max())), weights=weights)


#: Toward overspeed: samples continue each line beyond its last point at these fractions of the gap cap
#: (:func:`overspeed_evidence`: the largest relative N11 gap its hold-outs tested, times
#: :data:`hillchart.extension.hypotheses.OVERSPEED_GAP_CAP`).
OVERSPEED_FRACTIONS = (0.5, 1.0)


def overspeed_evidence(blade, n11, q11, m11) -> dict | None:
    """How well each line's straight continuation (:func:`hillchart.extension.band.continuation`) predicts
    the line's own highest-N11 point from the points below it (lines of 3 points or more; the lines are the units
    of evidence), and the band toward
    overspeed from those misses per relative N11 gap ``(N11 - N11_last) / N11_last``: log-ratios of Q11 and M11 as
    a share of the chart's M11 range, growing linearly with the gap (:func:`hillchart.extension.band.band_sides`),
    as a Francis chart's torque band toward runaway, up to ``gap_cap``. None when no line has 3 points."""
    from hillchart.extension.band import band_sides, continuation, log_ratio
    from hillchart.extension.hypotheses import OVERSPEED_GAP_CAP

    blade, n11, q11, m11 = (np.asarray(v, float) for v in (blade, n11, q11, m11))
    scale = max(float(np.ptp(m11)), 1e-12)
    q_res, m_res, gaps = [], [], []
    for line in np.unique(blade):
        on = np.flatnonzero(blade == line)
        if on.size < 3:
            continue
        end = on[np.argmax(n11[on])]
        rest = on[on != end]
        last = float(n11[rest].max())
        q_res.append(float(log_ratio(continuation(n11[rest], q11[rest], n11[end]), q11[end], 1e-9)))
        m_res.append((continuation(n11[rest], m11[rest], n11[end]) - m11[end]) / scale)
        gaps.append((n11[end] - last) / last)
    if not gaps:
        return None
    gaps, q_res, m_res = np.array(gaps), np.array(q_res), np.array(m_res)
    band_q = band_sides(q_res, gaps, lines=gaps.size, growth=1.0)
    band_m = band_sides(m_res, gaps, lines=gaps.size, growth=1.0)
    return {"points": int(gaps.size), "gap_cap": OVERSPEED_GAP_CAP * float(gaps.max()),
            "band_log_q11_per_gap": [float(v) for v in band_q], "band_m11_per_gap": [float(v) for v in band_m],
            "m11_scale": scale, "q11_rms": float(np.sqrt(np.mean(np.expm1(q_res) ** 2))),
            "m11_rms": float(np.sqrt(np.mean(m_res ** 2)))}


def overspeed_summary(over: dict | None) -> str:
    """What ``hillsim fccm`` prints of :func:`overspeed_evidence`."""
    if over is None:
        return "toward overspeed: no held-out evidence (no line of 3 points or more); the nets alone beyond the lines"
    low, high = over["band_log_q11_per_gap"]
    return (f"toward overspeed each line's straight continuation predicts its own highest-N11 point within "
            f"{100 * over['q11_rms']:.1f} % (Q11) and {100 * over['m11_rms']:.1f} % of the M11 range (RMS, "
            f"{over['points']} lines); samples continue each line up to {100 * over['gap_cap']:.0f} % beyond its "
            f"last N11, where the band spans {100 * math.expm1(-low * over['gap_cap']):+.1f} % to "
            f"{100 * math.expm1(high * over['gap_cap']):+.1f} % of Q11")


def on_cam_unit_samples(table, *, closed_angle_deg: float | None = None, zero_opening_points: int = 200,
                        seed: int = 0) -> tuple[dict, list[str], float]:
    """Unit samples (n11, opening = cam position c = phi - phi_closed in deg, q11, m11; ``measured`` marks the
    chart's own points) of an on-cam table
    (:func:`is_on_cam_table`), the notes on what was assumed, and phi_closed (deg).

    * M11 from the efficiency, eq. (5) of the BP hill-chart paper (``M11 = rho g Q11 eta / omega11``).
    * phi_closed: ``closed_angle_deg``, or :func:`closed_cam_angle` (a note says so).
    * Between the closed cam and the lowest line, at the lowest line's N11 (at :data:`SILENT_FRACTIONS` of the
      lowest line's c; assumed, a note says so): Q11 linear in c down to zero, the efficiency by
      :func:`silent_efficiency` with the weights of the chart's evidence.
    * The extension to the closed cam: ``zero_opening_points`` samples at c = 0 with Q11 = 0, M11 = 0 over N11
      from 0 to :data:`CLOSED_N11_FACTOR` times the table's largest (seeded).
    * ``evidence``: :func:`on_cam_evidence` (how well this answer predicts the chart's own lowest lines, and the
      band below the lowest line), ``silent_distance``: each sample's distance below the lowest line (0 on the
      chart's points; the members of :func:`train_on_cam_nets` move the samples between by the band there).
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
    # points, Q11 taken linear in the cam position down to zero at the closed cam, the efficiency as the chart's
    # own lowest lines weigh its hypotheses (linear to zero, or held: on_cam_evidence); M11 again from eq. (5)
    evidence = on_cam_evidence(blade, n11, q11, eta, None if closed_angle_deg is None else closed)
    low = blade == blade.min()
    frac = np.repeat(SILENT_FRACTIONS, int(low.sum()))
    q_s = frac * np.tile(q11[low], len(SILENT_FRACTIONS))
    n_s = np.tile(n11[low], len(SILENT_FRACTIONS))
    eta_s = silent_efficiency(np.tile(eta[low], len(SILENT_FRACTIONS)), frac, evidence.efficiency_held)
    m_s = np.asarray(unit_torque_from_efficiency(q_s, n_s, eta_s), float)
    c_s = frac * (blade.min() - closed)
    notes.append(f"below the lowest blade-angle line ({blade.min():g} deg): {q_s.size} samples with Q11 linear in "
                 f"the cam position down to zero at the closed cam and the efficiency "
                 f"{100 * evidence.efficiency_held:.0f} % held at the lowest line's, "
                 f"{100 * (1 - evidence.efficiency_held):.0f} % linear to zero (assumed, not charted)")
    # toward overspeed: each line continued straight beyond its last point, as far as its hold-outs were tested
    from hillchart.extension.band import continuation

    over = overspeed_evidence(blade, n11, q11, m11)
    n_o, c_o, q_o, m_o, gap_o = [], [], [], [], []
    if over is not None:
        for line in np.unique(blade):
            on = blade == line
            if on.sum() < 2:
                continue
            last = float(n11[on].max())
            for f in OVERSPEED_FRACTIONS:
                gap = f * over["gap_cap"]
                n_o.append(last * (1.0 + gap))
                c_o.append(line - closed)
                q_o.append(continuation(n11[on], q11[on], n_o[-1]))
                m_o.append(continuation(n11[on], m11[on], n_o[-1]))
                gap_o.append(gap)
    notes.append(overspeed_summary(over))
    k = int(zero_opening_points)
    rng = np.random.default_rng([seed, 3])
    # the closed cam passes no water at any unit speed: the samples reach twice the chart's largest N11, so that a
    # closing transient whose head falls (N11 = n D / sqrt(H) rises) meets no flow the nets invent past the chart
    n_o, c_o, q_o, m_o, gap_o = (np.array(v, float) for v in (n_o, c_o, q_o, m_o, gap_o))
    samples = {"n11": np.concatenate([n11, n_s, n_o, rng.uniform(0.0, CLOSED_N11_FACTOR * n11.max(), k)]),
               "opening": np.concatenate([blade - closed, c_s, c_o, np.zeros(k)]),
               "q11": np.concatenate([q11, q_s, q_o, np.zeros(k)]), "m11": np.concatenate([m11, m_s, m_o, np.zeros(k)]),
               "measured": np.concatenate([np.ones(n11.size, bool), np.zeros(q_s.size + n_o.size + k, bool)]),
               "silent_distance": np.concatenate([np.zeros(n11.size), 1.0 - frac, np.zeros(n_o.size), np.ones(k)]),
               "overspeed_gap": np.concatenate([np.zeros(n11.size + q_s.size), gap_o, np.zeros(k)]),
               "evidence": evidence, "overspeed": over}
    notes.append(evidence.summary())
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
    ``seed + 1``), the digitized region (convex hull of the samples marked ``measured``: the chart's points) and the
    plausibility checks on a grid over the cam's range and the N11 of the samples off the closed cam
    (``n11_checked``; the closed cam's zero-flow samples reach twice the chart's N11, where nothing else constrains
    the nets): Q11 falling as the cam opens, efficiency above 1 where Q11 is above 5 % of its largest value, the
    ensemble's spread (5-95 % of Q11 and M11, as % of their ranges).

    With ``members`` > 1, an ensemble of ``members`` more pairs (seeds ``seed + 2``, ``seed + 4``, ...), each
    trained on the samples with those below the lowest line (``silent_distance`` > 0) moved to the member's place
    in the band of the chart's evidence (``samples["evidence"]``, :class:`OnCamEvidence`; places ``u``,
    :func:`hillchart.extension.band.member_positions`): Q11 times ``exp(u w(d))`` and M11 plus ``u w_M(d)``, ``w``
    and ``w_M`` the band's side at the sample's distance, so the members' 5-95 % band below the lowest line is the
    evidence's. The chart's own points never move.

    Returns
    -------
    nets : HillNets
    report : dict
        ``plausibility`` figures and ``warnings``.
    """
    from scipy.spatial import ConvexHull

    from hillchart.extension.band import member_positions
    from hillchart.fccm.net import FCCMNet
    from hillchart.nets.hill_nets import HillNets

    X = np.column_stack([np.asarray(samples[k], float) for k in ON_CAM_INPUTS])
    evidence = samples.get("evidence")
    places = [0.0]  # the point nets, on the samples as they are
    if members > 1:
        places += [float(u) for u in member_positions(members, seed)]
    d = np.asarray(samples.get("silent_distance", np.zeros(len(X))), float)
    if evidence is not None:
        (q_low, q_high), (m_low, m_high) = evidence.q11_widths(d), evidence.m11_widths(d)
    else:
        q_low = q_high = m_low = m_high = np.zeros(len(X))
    q_low, q_high, m_low, m_high = (np.where(d > 0.0, v, 0.0) for v in (q_low, q_high, m_low, m_high))
    over, gap = samples.get("overspeed"), np.asarray(samples.get("overspeed_gap", np.zeros(len(X))), float)
    if over is not None:  # toward overspeed: the band of the lines' own last points, linear in the gap
        (ql, qh), (ml, mh) = over["band_log_q11_per_gap"], over["band_m11_per_gap"]
        scale = over["m11_scale"]
        q_low, q_high = q_low + ql * gap, q_high + qh * gap
        m_low, m_high = m_low + ml * scale * gap, m_high + mh * scale * gap
    pairs = []
    for i, u in enumerate(places):
        moved = {"q11": np.asarray(samples["q11"], float) * np.exp(u * (q_low if u < 0 else q_high)),
                 "m11": np.asarray(samples["m11"], float) + u * (m_low if u < 0 else m_high)}
        pair = []
        for offset, out in enumerate(("q11", "m11")):
            est = FCCMNet(hidden=hidden, restarts=restarts, seed=seed + 2 * i + offset, split=split).fit(
                X, moved[out], input_names=ON_CAM_INPUTS, output_names=(out,))
            pair.append(_net_weights(est.weights_))
        pairs.append(tuple(pair))
    digitized = X[np.asarray(samples["measured"], bool)]
    region = digitized[ConvexHull(digitized).vertices]
    training = {"kind": "on-cam", "hidden": hidden, "restarts": restarts, "split": list(split),
                "n_samples": int(len(X)), "ensemble_seeds": [seed + 2 * i for i in range(1, len(pairs))],
                "ensemble_places": places[1:]}
    if evidence is not None:
        training["evidence"] = evidence.to_dict()
    if samples.get("overspeed") is not None:
        training["overspeed_evidence"] = dict(samples["overspeed"], summary=overspeed_summary(samples["overspeed"]))
    nets = HillNets(flow=pairs[0][0], torque=pairs[0][1], opening_unit="deg (cam)", training=training,
                    ensemble=pairs[1:] or None, digitized_region=region)
    # the checks' box: the cam from closed to open, N11 over the chart's points and the samples that continue them
    # (below the lowest line, toward overspeed); the closed cam's zero-flow samples reach twice the chart's N11, where
    # nothing else constrains the nets and a run reading them is warned of leaving the digitized region
    informed = np.asarray(samples["opening"], float) > 0.0
    lo = np.array([X[informed, 0].min(), X[:, 1].min()])
    hi = np.array([X[informed, 0].max(), X[:, 1].max()])
    n11, c = (v.ravel() for v in np.meshgrid(*(np.linspace(lo[j], hi[j], 20) for j in range(2)), indexing="ij"))
    q = nets.q11(n11, c)
    dq_dc = nets.q11_grad(n11, c)[1]
    eta = np.where(q > 0.05 * q.max(), nets.efficiency(n11, c), np.nan)  # near-zero flow: a ratio of small numbers
    drawn = pairs[1:] or pairs
    q_all = np.array([f.evaluate(n11, c)[0] for f, _ in drawn])
    m_all = np.array([t.evaluate(n11, c)[0] for _, t in drawn])

    def spread(values, key):
        band = np.percentile(values, 95, axis=0) - np.percentile(values, 5, axis=0)
        return 100.0 * float(np.median(band) / max(np.ptp(samples[key]), 1e-12))

    p = {"n11_checked": [float(lo[0]), float(hi[0])], "share_dq11_dc_negative": float(np.mean(dq_dc < 0)),
         "share_efficiency_above_1": float(np.mean(np.nan_to_num(eta) > 1.0)), "max_efficiency": float(np.nanmax(eta)),
         "ensemble_members": len(drawn), "ensemble_spread_q11_pct": spread(q_all, "q11"),
         "ensemble_spread_m11_pct": spread(m_all, "m11")}
    warnings = [ON_CAM_WARNING]
    if p["share_dq11_dc_negative"] > 0.05:
        warnings.append(f"Q11 falls as the cam opens on {100 * p['share_dq11_dc_negative']:.0f} % of the checked box: "
                        "the nets fit noise or the table is thin there; check the table, fewer hidden neurons "
                        "(--hidden)")
    if p["share_efficiency_above_1"] > 0:
        warnings.append(f"the nets' efficiency exceeds 1 on {100 * p['share_efficiency_above_1']:.1f} % of the "
                        f"checked box (max {p['max_efficiency']:.3f}): implausible; check the table's efficiency "
                        "column (a fraction) and --closed-opening")
    nets.training["plausibility"] = p
    return nets, {"plausibility": p, "warnings": warnings}
