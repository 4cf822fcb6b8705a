"""Where a guarantee figure was decided, and what the characteristics rest on there.

A banded figure (:data:`simulate.studies.uncertainty.BAND_FIGURES`) is judged on its conservative end. This module
says, per figure, which run that end came from, when and at which operating point that run reached its extremum,
which region of the chart the point lies in, and the evidence behind the characteristics in that region:

conservative end     the band's upper end, never milder than the point nets' own figure (every banded figure is
                     worse when larger: a rise, a drop, a head), the rule of
                     :meth:`simulate.studies.cases.Limits.check`.
deciding run         the point nets when their figure is that end (the band's end is milder); else the ensemble
                     member with the largest figure. The band's end is a percentile of the members' figures
                     widened about their median (:func:`simulate.studies.uncertainty.figure_band`), not one member's
                     figure: that member is the run that reaches furthest toward it.
deciding point       the time step of the run's extremum (of the unit that gives the plant-level figure when the
                     plant has several) with N11 = n D1 / sqrt(H) (:func:`hillchart.characteristics.unit_quantities`)
                     and the opening (chart units) there.
region               ``below_lowest_line``: the opening is below the lowest digitized opening line (the
                     silent-region table's, else the smallest opening of the digitized region), where the table
                     of weighed hypotheses answers at any N11 (:mod:`hillchart.nets.silent_model`);
                     ``digitized``: inside the digitized region (the hull the simulator's extrapolation record
                     checks, :mod:`simulate.loop.domain`); ``toward_runaway``: outside it beyond its largest N11 at
                     that opening; ``below_smallest_n11``: outside it below its smallest N11;
                     ``above_largest_line``: above its largest opening; ``unknown``: the nets record no digitized
                     region.

The evidence is read from the nets' training record (nets.json ``training.extrapolation`` and the ``silent_model``
band): below the lowest line the hypotheses' weights, each one's held-out Q11 and M11 errors on the chart's own
lowest line(s), the hypothesis whose value their weighed median takes at the point (``median_of``, for Q11 and for
M11: the one that decided the figure there, :func:`median_hypotheses`) and the band's two sides at the point; toward
runaway the held-out line ends and the torque band at the point's gap; in the digitized region the fit's RMS errors
at the measured samples. The nets of an on-cam chart (:mod:`hillchart.fccm.on_cam`) are quoted from their own
records (``training.evidence`` below the lowest line, ``training.overspeed_evidence`` beyond the lines' ends). A
nets.json without that record says so: no held-out evidence is made up.
"""

from __future__ import annotations

import math

import numpy as np

from hillchart.characteristics import unit_quantities
from hillchart.errors import NumericalError
from simulate.results.result import extremum_index
from simulate.studies.uncertainty import BAND_FIGURES

#: The series and sense of each banded figure's extremum (SimulationResult attribute, +1 maximum, -1 minimum).
FIGURE_TRACES = {"max_speed_rise": ("speed_rpm", 1.0), "max_head_rise": ("head_m", 1.0),
                 "min_head_drop": ("head_m", -1.0), "max_head_m": ("head_m", 1.0)}
#: Each region in words.
REGIONS = {"below_lowest_line": "below the lowest digitized opening line",
           "digitized": "inside the digitized chart",
           "toward_runaway": "beyond the last digitized N11 toward runaway",
           "below_smallest_n11": "below the smallest digitized N11",
           "above_largest_line": "above the largest digitized opening line",
           "unknown": "unknown (the nets record no digitized region)"}
#: Keys of a single-regulated chart's held-out record (:meth:`hillchart.extension.hypotheses.Extrapolation.to_dict`).
HELD_OUT_KEYS = ("weights", "rms_error", "held_out_points", "held_out_lines", "lowest_opening")
#: What answers outside the digitized chart without the hypotheses' record, and why there is no evidence.
NETS_ALONE = "the nets alone, extrapolating the extension's samples"
NO_RECORD = ("this nets.json has no silent_model block and no held-out record (a file of an earlier version, or "
             "trained with --no-silent-regions or --boundaries polynomial): outside the digitized chart the nets "
             "extrapolate the extension's samples, which no held-out line has tested")
#: Relative tolerance of a deciding member's re-run against its figure in the band: the same plant and member run
#: the same compiled loop, so the figure repeats to rounding.
RERUN_RTOL = 1e-9


def hull_span(hull: np.ndarray, opening: float) -> tuple[float, float] | None:
    """``(N11 min, N11 max)`` of the convex polygon ``hull`` (vertices (N11, opening)) at ``opening``, or None
    where the opening is outside its range.

    Examples
    --------
    >>> square = np.array([[40.0, 10.0], [90.0, 10.0], [80.0, 30.0], [45.0, 30.0]])
    >>> hull_span(square, 20.0), hull_span(square, 31.0)
    ((42.5, 85.0), None)
    """
    xs = []
    for (x0, y0), (x1, y1) in zip(hull, np.roll(hull, -1, axis=0)):
        if min(y0, y1) <= opening <= max(y0, y1):
            xs.extend([x0, x1] if y0 == y1 else [x0 + (opening - y0) * (x1 - x0) / (y1 - y0)])
    return (float(min(xs)), float(max(xs))) if xs else None


def _silent_table(characteristics):
    """The single-regulated silent-region table of the characteristics, or None."""
    from hillchart.nets.silent_model import SilentRegionModel

    table = getattr(characteristics, "silent_model", None)
    return table if isinstance(table, SilentRegionModel) else None


def held_out_record(characteristics) -> dict | None:
    """The chart's held-out record below its lowest line (``training.extrapolation`` with :data:`HELD_OUT_KEYS`),
    or None when the nets carry none (a legacy or ``--no-silent-regions`` file, or another kind of chart)."""
    record = (getattr(characteristics, "training", None) or {}).get("extrapolation")
    return record if isinstance(record, dict) and all(k in record for k in HELD_OUT_KEYS) else None


def _other_kind(characteristics) -> bool:
    """Whether the characteristics keep an extrapolation of another kind than a single-regulated chart's (a
    double-regulated table's silent model or record, :mod:`hillchart.fccm.evidence`), which this module does not
    read."""
    table = getattr(characteristics, "silent_model", None)
    record = (getattr(characteristics, "training", None) or {}).get("extrapolation")
    return (table is not None and _silent_table(characteristics) is None) or (
        isinstance(record, dict) and held_out_record(characteristics) is None)


#: The evidence of characteristics of :func:`_other_kind`.
NOT_READ = ("the characteristics' own extrapolation", {
    "kind": "not_read", "text": "these characteristics keep their extrapolation and its evidence in another form (a "
                                "double-regulated table's held-out angles, hillsim fccm), which this report does not "
                                "read"})


#: What an on-cam chart's nets (:mod:`hillchart.fccm.on_cam`) answer with outside the chart, per region, and the key of
#: their held-out record in ``training``.
ON_CAM = {"below_lowest_line": ("the on-cam extension below the lowest blade-angle line (Q11 linear in the cam to the "
                                "closed cam, the efficiency weighed by the chart's own lowest lines)", "evidence"),
          "toward_runaway": ("the on-cam lines' straight continuation beyond their last points",
                             "overspeed_evidence")}


def _on_cam(characteristics, region: str) -> tuple[str, dict] | None:
    """``(decided by, evidence)`` of on-cam nets in a region :data:`ON_CAM` names (the record's own summary, as
    ``hillsim fccm`` printed it), or None for other characteristics or regions."""
    training = getattr(characteristics, "training", None) or {}
    if training.get("kind") != "on-cam" or region not in ON_CAM:
        return None
    decided, key = ON_CAM[region]
    record = training.get(key)
    if not isinstance(record, dict) or "summary" not in record:
        return decided, {"kind": "none", "text": f"no held-out evidence: this on-cam nets.json has no "
                                                 f"training.{key} record (a file of an earlier version: train it "
                                                 f"again with hillsim fccm --simulator-nets)"}
    return decided, {"kind": "on_cam_held_out", "record": key, "text": record["summary"]}


def lowest_opening(characteristics, hull) -> tuple[float | None, str]:
    """``(opening, source)`` of the lowest digitized opening line (chart units): the silent-region table's, else the
    held-out record's, else the digitized region's smallest opening; ``(None, "")`` when none is known."""
    table = _silent_table(characteristics)
    if table is not None:
        return float(table.blend_openings[1]), "silent_model.blend_openings"
    record = held_out_record(characteristics)
    if record is not None:
        return float(record["lowest_opening"]), "training.extrapolation.lowest_opening"
    if hull is not None and len(hull) >= 3:
        return float(np.min(hull[:, 1])), "digitized_region"
    return None, ""


def classify(n11: float, opening: float, hull, lowest: float | None) -> tuple[str, dict]:
    """``(region, details)`` of the operating point (``n11`` r/min, ``opening`` chart units) against the digitized
    region ``hull`` (vertices, or None) and the lowest digitized opening ``lowest`` (module docstring). ``details``:
    ``distance`` below the lowest line (1 - a / a_low), or the region's N11 edge at that opening and the relative
    ``gap`` beyond it.

    Examples
    --------
    >>> hull = np.array([[40.0, 10.0], [90.0, 10.0], [80.0, 30.0], [45.0, 30.0]])
    >>> [classify(n, a, hull, 10.0)[0] for n, a in ((60.0, 20.0), (100.0, 2.5), (102.0, 20.0), (30.0, 20.0))]
    ['digitized', 'below_lowest_line', 'toward_runaway', 'below_smallest_n11']
    >>> round(classify(102.0, 20.0, hull, 10.0)[1]["gap"], 6)  # (102 - 85) / 85
    0.2
    """
    from simulate.loop.domain import inside_hull

    if lowest is not None and opening < lowest * (1.0 - 1e-9):
        return "below_lowest_line", {"lowest_opening": lowest, "distance": 1.0 - opening / lowest}
    if hull is None or len(hull) < 3:
        return "unknown", {}
    if bool(inside_hull(hull, n11, opening, scale=np.ptp(hull, axis=0))[()]):
        return "digitized", {}
    span = hull_span(hull, opening)
    if span is None:
        return ("above_largest_line" if opening > np.max(hull[:, 1]) else "below_lowest_line"), {}
    if n11 > span[1]:
        return "toward_runaway", {"edge_n11_rpm": span[1], "gap": (n11 - span[1]) / span[1]}
    return "below_smallest_n11", {"edge_n11_rpm": span[0]}


def deciding_point(result, plant, figure: str) -> dict:
    """The time step of ``figure``'s extremum in ``result`` and the operating point there (module docstring):
    ``unit`` (None for a plant of one unit), ``time_s``, ``speed_rpm``, ``head_m``, ``flow_m3_s``, ``opening``
    (chart units), ``n11_rpm``, ``q11_m3_s``."""
    from simulate.loop.common import HEAD_FLOOR_FRACTION
    from simulate.results.result import unit_series

    trace, sense = FIGURE_TRACES[figure]
    series = unit_series(result, plant)
    if len(series) > 1:  # the plant-level figure is the worst over the units: the unit that gives it
        unit = result.summary()[f"{figure}_unit"]
        name, s, d1 = next(item for item in series if item[0] == unit)
    else:
        name, s, d1 = series[0]
    i = extremum_index(trace, s[trace], sense)  # the sample the summary's figure reads
    rated_head = (plant.turbine if name is None else plant.unit_plant(
        next(u for u in plant.units if u.name == name)).turbine).rated_head_m
    head = max(float(s["head_m"][i]), HEAD_FLOOR_FRACTION * rated_head)  # the floor of the simulator's own N11
    n11, q11 = unit_quantities(s["speed_rpm"][i], s["flow_m3_s"][i], head, d1)
    return {"unit": name, "time_s": float(result.time_s[i]), "speed_rpm": float(s["speed_rpm"][i]),
            "head_m": float(s["head_m"][i]), "flow_m3_s": float(s["flow_m3_s"][i]),
            "opening": float(s["opening_chart"][i]), "n11_rpm": float(n11), "q11_m3_s": float(q11)}


def _pct(x: float) -> str:
    return f"{100.0 * x:.2f} %"


def median_hypotheses(record: dict, n11: float, opening: float) -> dict | None:
    """``{"q11": names, "m11": names}``: the hypotheses whose values the weighed median takes at the nodes of the
    table's cell around (``n11`` r/min, ``opening``) (the table interpolates between them), heaviest first, from the
    record's ``median_of`` (:func:`hillchart.nets.silent_model.median_of`); None where the record does not hold it
    (a nets.json of an earlier version).

    Examples
    --------
    >>> record = {"hypotheses": ["model", "line"], "weights": {"q11": {"model": 0.6, "line": 0.4},
    ...           "m11": {"model": 0.6, "line": 0.4}}, "median_of": {"n11_top": 100.0, "lowest_opening": 10.0,
    ...           "q11": [[0, 0], [0, 1], [1, 1]], "m11": [[0, 0], [0, 0], [0, 0]]}}
    >>> median_hypotheses(record, 20.0, 5.0)
    {'q11': ['model', 'line'], 'm11': ['model']}
    >>> median_hypotheses(record, 150.0, 5.0)["q11"], median_hypotheses({}, 20.0, 5.0)
    (['line'], None)
    """
    table = record.get("median_of")
    if not isinstance(table, dict):
        return None
    out = {}
    for target in ("q11", "m11"):
        grid = np.asarray(table[target], int)
        # the nodes that bound the point along each axis (one, where the point lies on a node or beyond the table)
        at = (np.clip(x / top, 0.0, 1.0) * (size - 1) for x, top, size in
              ((n11, table["n11_top"], grid.shape[0]), (opening, table["lowest_opening"], grid.shape[1])))
        cell = grid[np.ix_(*(sorted({math.floor(x), math.ceil(x)}) for x in at))].ravel()
        weights = record["weights"][target]
        out[target] = sorted({record["hypotheses"][k] for k in cell}, key=lambda h: -weights[h])
    return out


def _below_lowest_line(characteristics, member, details, opening, n11) -> tuple[str, dict]:
    record, table = held_out_record(characteristics), _silent_table(characteristics)
    if record is None:
        if table is not None:  # a file of an earlier version: the fitted physical model itself, tabulated
            return ("the fitted physical model of an earlier nets.json (no hypotheses weighed)",
                    {"kind": "none", "text": "no held-out evidence: this nets.json holds the fitted physical model "
                     "below the lowest line without the hypotheses' held-out record (training.extrapolation); "
                     "retrain with hillsim train to weigh them"})
        return NETS_ALONE, {"kind": "none", "text": f"no held-out evidence: {NO_RECORD}"}
    evidence = {"kind": "held_out_lines", "held_out_points": int(record["held_out_points"]),
                "held_out_lines": record["held_out_lines"], "weights": record["weights"],
                "rms_error": record["rms_error"], "lowest_opening": details["lowest_opening"],
                "distance": details["distance"]}
    if table is not None:
        sides = table.band_sides(opening)
        evidence.update(band_q11=list(sides["q11"]), band_m11_nm=list(sides["m11_nm"]),
                        nets_weight=table.nets_weight(opening))
    position = None if member is None or _silent_table(member) is None else _silent_table(member).position
    evidence["member_position"] = position
    if not record["held_out_points"]:
        evidence["kind"] = "no_held_out_lines"
        evidence["text"] = ("no held-out evidence: the chart has too few opening lines to hold any out; the "
                            "hypotheses are weighed equally and the band is the wide default")
        return "the extrapolation hypotheses, weighed equally", evidence
    weights, errors = record["weights"], record["rms_error"]
    ranked = sorted((h for h in weights["q11"] if h in errors["q11"]),  # the hypotheses weighed
                    key=lambda h: -(weights["q11"][h] + weights["m11"][h]))
    text = (f"opening {opening:.4g} below the lowest line's {details['lowest_opening']:.4g} (distance "
            f"1 - a / a_low = {details['distance']:.2f}); weights Q11/M11 and held-out RMS error Q11/M11 (M11 as "
            f"a share of its measured range) on the chart's own lowest lines, held out "
            f"{' and '.join(str(k) for k in record['held_out_lines'])} at a time ({record['held_out_points']} "
            f"points): "
            + ", ".join(f"{h} {weights['q11'][h]:.2f}/{weights['m11'][h]:.2f} ({_pct(errors['q11'][h])}/"
                        f"{_pct(errors['m11'][h])})" for h in ranked)
            + f"; their weighed median {_pct(errors['q11']['blend'])}/{_pct(errors['m11']['blend'])}")
    median = median_hypotheses(record, n11, opening)
    evidence["median_of"] = median
    if median is not None:
        text += ("; here the median is " + " and ".join(
            f"{' / '.join(median[t])}'s {label} (held-out "
            + " / ".join(_pct(errors[t][h]) if h in errors[t] else "untested" for h in median[t]) + ")"
            for t, label in (("q11", "Q11"), ("m11", "M11"))))
    else:
        text += ("; which hypothesis the median takes here this nets.json does not record (written by an earlier "
                 "version: retrain with hillsim train to record it)")
    if table is not None:
        text += (f"; the band here: Q11 {100 * sides['q11'][0]:+.1f} % to {100 * sides['q11'][1]:+.1f} %, M11 "
                 f"{sides['m11_nm'][0]:+.4g} to {sides['m11_nm'][1]:+.4g} N*m; the nets' weight in the blend "
                 f"{evidence['nets_weight']:.2f}")
    if position is not None:
        text += f"; this member stands at {position:+.2f} in the band (+-1: its 5-95 % edges)"
    evidence["text"] = text
    decided = "the weighed median of the extrapolation hypotheses (weighed by the chart's held-out lines)"
    if median is not None:
        decided += f": here the {' / '.join(median['q11'])} (Q11) and the {' / '.join(median['m11'])} (M11)"
    return decided, evidence


def _bare_lines(characteristics, opening: float) -> list[float]:
    """The lines (chart units) beyond whose last point the chart's fitted model gave no runaway speed
    (``training.lines_without_runaway``, :func:`hillchart.extension.silent_samples.lines_without_runaway`), when
    the point's ``opening`` lies at or above the smallest of them: there no sample constrained the nets toward
    runaway."""
    lines = (getattr(characteristics, "training", None) or {}).get("lines_without_runaway") or []
    return [float(a) for a in lines] if lines and opening >= min(lines) * (1.0 - 1e-9) else []


def _toward_runaway(characteristics, details, opening: float) -> tuple[str, dict]:
    from hillchart.extension.silent_samples import openings_text

    bare = _bare_lines(characteristics, opening)
    record = held_out_record(characteristics)
    overspeed = (record or {}).get("overspeed")
    if bare:
        where = (f"N11 {100 * details['gap']:.1f} % beyond the digitized region's edge ({details['edge_n11_rpm']:.4g} "
                 f"r/min) at this opening; the chart has no runaway curve and its fitted model gives no runaway speed "
                 f"beyond the lines a = {openings_text(bare)}")
        if isinstance(overspeed, dict) and details["gap"] <= overspeed["gap_cap"]:
            # within the gap the held-out line ends tested twice over, the lines' straight continuations answer
            # (hillchart.extension.silent_samples.continued_line_points)
            return ("the straight continuation of the lines toward runaway",
                    {"kind": "held_out_line_ends", "held_out_points": overspeed["held_out_points"],
                     "line_m11_rms": overspeed["line_m11_rms"], "gap": details["gap"],
                     "text": f"{where}: each line's last point held out ({overspeed['held_out_points']} points), a "
                             f"straight continuation of each line predicts them within "
                             f"{_pct(overspeed['line_q11_rms'])} (Q11) and {_pct(overspeed['line_m11_rms'])} of the "
                             "M11 range"})
        if isinstance(overspeed, dict):
            where += (f", their straight continuations sampled {100 * overspeed['gap_cap']:.0f} % beyond their ends "
                      "only")
        return (f"{NETS_ALONE}: no sample constrains them toward runaway here",
                {"kind": "none", "text": f"{where}: the figure is the nets' extrapolation alone; give the runaway "
                                         "curve (runaway.csv) and train again"})
    if record is None:
        return NETS_ALONE, {"kind": "none", "text": f"no held-out evidence: {NO_RECORD}"}
    decided = "the extension toward runaway (the fitted model's overspeed samples)"
    if not isinstance(overspeed, dict):
        return decided, {"kind": "none", "text": "no held-out evidence toward runaway in this nets.json (its "
                                                 "chart has no line of 3 points to hold the last one out)"}
    gap = details["gap"]
    band = overspeed["m11_band_per_gap"]
    # the torque band at this gap, as Extrapolation.overspeed_widths draws it beyond a line's last point (per unit
    # gap, capped); between the lines the region's edge at this opening stands in for the line's last point
    reach = min(gap, overspeed["gap_cap"])
    sides = [-band["low"] * reach, band["high"] * reach]
    evidence = {"kind": "held_out_line_ends", "held_out_points": overspeed["held_out_points"],
                "model_q11_rms": overspeed["model_q11_rms"], "model_m11_rms": overspeed["model_m11_rms"],
                "line_q11_rms": overspeed["line_q11_rms"], "line_m11_rms": overspeed["line_m11_rms"],
                "runaway_n11_rms": overspeed["runaway_n11_rms"], "edge_n11_rpm": details["edge_n11_rpm"],
                "gap": gap, "band_m11_range": sides,
                "band_m11_nm": [v * overspeed["m11_scale"] for v in sides]}
    text = (f"N11 {100 * gap:.1f} % beyond the digitized region's edge ({details['edge_n11_rpm']:.4g} r/min) at "
            f"this opening; each line's last point held out ({overspeed['held_out_points']} points): the model "
            f"predicts them within {_pct(overspeed['model_q11_rms'])} (Q11) and {_pct(overspeed['model_m11_rms'])} "
            f"of the M11 range, a straight continuation of each line within {_pct(overspeed['line_q11_rms'])} and "
            f"{_pct(overspeed['line_m11_rms'])}")
    if overspeed["runaway_n11_rms"] is not None:
        text += f"; held-out runaway speeds within {_pct(overspeed['runaway_n11_rms'])}"
    evidence["text"] = text + (f"; the torque band here {100 * sides[0]:+.2f} % to {100 * sides[1]:+.2f} % of the "
                               f"M11 range")
    return decided, evidence


def _digitized(characteristics, point) -> tuple[str, dict]:
    training = getattr(characteristics, "training", None) or {}
    fits = {key: training[key].get("measured_rms_error") if isinstance(training.get(key), dict) else None
            for key in ("flow", "torque")}
    if fits["flow"] is None or fits["torque"] is None:
        return "the measured chart", {"kind": "none", "text": "the nets record no RMS error at the measured samples"}
    q11 = point["q11_m3_s"]
    return "the measured chart", {
        "kind": "fit", "q11_rms_m3_s": fits["flow"], "m11_rms_nm": fits["torque"],
        "text": f"the nets' RMS error at the measured samples: Q11 {fits['flow']:.3g} m3/s "
                f"({_pct(fits['flow'] / q11) if q11 > 0 else 'n/a'} of Q11 here), M11 {fits['torque']:.3g} N*m"}


def region_evidence(characteristics, member, region: str, details: dict, point: dict) -> tuple[str, dict]:
    """``(decided by, evidence)`` of an operating point in ``region`` (module docstring); ``member``: the deciding
    ensemble member's characteristics, or None for the point nets. ``evidence`` has ``kind`` (``none`` where there
    is no evidence) and ``text``."""
    if region == "unknown":
        return "not placed", {"kind": "not_placed", "text": "the nets record no digitized region (and no flow.csv "
                                                            "lies beside them), so the point cannot be placed on the "
                                                            "chart nor its evidence read"}
    on_cam = _on_cam(characteristics, region)
    if on_cam is not None:
        return on_cam
    if region in ("below_lowest_line", "toward_runaway") and _other_kind(characteristics):
        return NOT_READ[0], dict(NOT_READ[1])
    if region == "below_lowest_line":
        return _below_lowest_line(characteristics, member, details, point["opening"], point["n11_rpm"])
    if region == "toward_runaway":
        return _toward_runaway(characteristics, details, point["opening"])
    if region == "digitized":
        return _digitized(characteristics, point)
    return "the nets' extrapolation", {"kind": "none", "text": "no held-out evidence for this region of the chart"}


def figure_origins(plant, characteristics, result, band: dict | None = None) -> tuple[dict, dict]:
    """Per banded figure of ``result`` (the point nets' run of ``plant``), where its conservative end was decided
    and the evidence there (module docstring).

    Parameters
    ----------
    plant : PlantConfig
    characteristics
        The point nets the run used (their ``members()`` ran the band).
    result : SimulationResult
    band : dict, optional
        :func:`simulate.studies.uncertainty.run_ensemble`'s figures; None: the point nets decide every figure.

    Returns
    -------
    origins : dict
        ``{figure: {"conservative_end", "point_value", "band", "member", "run", "unit", "time_s", "speed_rpm",
        "head_m", "flow_m3_s", "opening", "n11_rpm", "q11_m3_s", "region", "region_text", "details",
        "decided_by", "evidence"}}``; ``member`` None for the point nets.
    member_runs : dict
        ``{member index: SimulationResult}`` of the deciding members (run again: the band keeps figures only).

    Raises
    ------
    NumericalError
        A deciding member's run does not repeat its figure in the band (to :data:`RERUN_RTOL`).
    """
    from simulate.loop.domain import plant_domain
    from simulate.loop.engine import run_simulation

    summary = result.summary()
    members = characteristics.members() if band is not None else []
    failed = set() if band is None else {f["member"] for f in band["failed"]}
    ran = [i for i in range(len(members)) if i not in failed]
    member_runs, origins = {}, {}
    for figure in BAND_FIGURES:
        value = float(summary[figure])
        entry = None if band is None else band[figure]
        member, run, end = None, result, value
        if entry is not None and float(entry["high"]) > value:
            k = int(np.argmax(entry["values"]))
            member, end = ran[k], float(entry["high"])
            if member not in member_runs:
                member_runs[member] = run_simulation(plant, characteristics=members[member])
            run = member_runs[member]
            again = float(run.summary()[figure])
            if not math.isclose(again, entry["values"][k], rel_tol=RERUN_RTOL, abs_tol=1e-15):
                raise NumericalError(f"{figure}: ensemble member {member} gives {again!r} when run again, "
                                     f"{entry['values'][k]!r} in the band (relative tolerance {RERUN_RTOL:g})")
        point = deciding_point(run, plant, figure)
        view = plant if point["unit"] is None else plant.unit_plant(
            next(u for u in plant.units if u.name == point["unit"]))
        hull = plant_domain(view, characteristics).hull
        lowest, _ = lowest_opening(characteristics, hull)
        region, details = classify(point["n11_rpm"], point["opening"], hull, lowest)
        decided_by, evidence = region_evidence(characteristics, None if member is None else members[member],
                                               region, details, point)
        origins[figure] = {
            "conservative_end": end, "point_value": value,
            "band": None if entry is None else [float(entry["low"]), float(entry["high"])],
            "member": member, "member_value": None if member is None else float(entry["values"][ran.index(member)]),
            "run": "point nets" if member is None else f"ensemble member {member}", **point,
            "region": region, "region_text": REGIONS[region], "details": details,
            "decided_by": decided_by, "evidence": evidence}
    return origins, member_runs
