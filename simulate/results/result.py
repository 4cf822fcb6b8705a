"""SimulationResult: the record a run returns (time series in physical units, summary, files on request)."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from simulate.results.envelope import envelope_summary, envelope_warnings
from simulate.results.figures import save_png

#: Per-unit columns of a plant with several units (``U1.speed_rpm``, ...), in order.
#: Legend of the shaded intervals of :meth:`SimulationResult.plot`: where the trajectory leaves the chart
#: (simulate.loop.domain: outside the digitized region, outside the nets' training range, or beyond full stroke).
EXTRAPOLATED_LABEL = "extrapolated: outside the digitized chart, the nets' range or full stroke"
UNIT_COLUMNS = ("speed_rpm", "head_m", "flow_m3_s", "opening", "opening_chart", "torque_nm", "power_mw", "iterations")
#: Figures of the plant that are the worst over its units (``max``: the largest unit value, ``min``: the smallest),
#: with the figure that gives the time and the unit.
WORST_FIGURES = {"max_speed_rise": ("max", "t_max_speed_s"), "max_speed_rpm": ("max", "t_max_speed_s"),
                 "max_head_rise": ("max", "t_max_head_s"), "max_head_m": ("max", "t_max_head_s"),
                 "min_head_drop": ("max", "t_min_head_s"), "min_head_m": ("min", "t_min_head_s")}


def largest_speed_index(speed_rpm) -> int:
    """The sample of the largest speed *magnitude*: the overspeed a guarantee reads, in either direction of rotation
    (a pump's runner that trips turns back and runs away as a turbine; a unit that never reverses has the largest
    speed there, as before)."""
    return int(np.argmax(np.abs(np.asarray(speed_rpm, float))))


def extremum_index(trace: str, values, sense: float) -> int:
    """The sample a guarantee figure reads on its series ``trace``: the speed by its magnitude, in either direction
    (:func:`largest_speed_index`), any other series at its maximum (``sense`` > 0) or minimum. The one place the
    summary's figures, their marks on the figure and their origin (:mod:`simulate.studies.figure_origin`) agree on."""
    if trace == "speed_rpm":
        return largest_speed_index(values)
    values = np.asarray(values, float)
    return int(np.argmax(values)) if sense > 0 else int(np.argmin(values))


def speed_base_rpm(initial_speed_rpm: float, rated_speed_rpm: float) -> float:
    """What the max speed rise is a rise over: |n0|, or the rated speed for a run from standstill (n0 = 0)."""
    return abs(float(initial_speed_rpm)) if initial_speed_rpm != 0.0 else float(rated_speed_rpm)


def speed_figures(time_s, speed_rpm, rated_speed_rpm: float) -> dict:
    """``max_speed_rise`` (|n| at :func:`largest_speed_index` over |n0|, minus 1; over the rated speed for a run
    that starts at standstill, n0 = 0), ``t_max_speed_s`` and ``max_speed_rpm`` (that largest |n|, r/min).

    Examples
    --------
    >>> f = speed_figures(np.array([0.0, 1.0, 2.0, 3.0]), np.array([-100.0, -60.0, 20.0, 130.0]), 100.0)
    >>> round(f["max_speed_rise"], 9), f["t_max_speed_s"], f["max_speed_rpm"]
    (0.3, 3.0, 130.0)
    >>> round(speed_figures(np.array([0.0, 1.0]), np.array([0.0, 104.0]), 100.0)["max_speed_rise"], 9)  # start-up
    0.04
    """
    speed = np.asarray(speed_rpm, float)
    i = largest_speed_index(speed)
    rise = float(abs(speed[i]) / speed_base_rpm(speed[0], rated_speed_rpm) - 1.0)
    return {"max_speed_rise": rise, "t_max_speed_s": float(time_s[i]),
            "max_speed_rpm": float(abs(speed[i]))}


def unit_figures(time_s: np.ndarray, series: dict, rated_speed_rpm: float) -> dict:
    """Summary figures of one unit of a plant with several units (the names and meanings of
    :meth:`SimulationResult.summary`); ``series`` holds :data:`UNIT_COLUMNS` and ``speed_reference_rpm``.

    Examples
    --------
    >>> t = np.array([0.0, 1.0, 2.0])
    >>> u = {"speed_rpm": np.array([100.0, 110.0, 100.0]), "head_m": np.array([50.0, 60.0, 45.0]),
    ...      "flow_m3_s": t, "opening": t, "power_mw": t, "speed_reference_rpm": 100.0}
    >>> f = unit_figures(t, u, 100.0)
    >>> round(f["max_speed_rise"], 9), f["t_max_head_s"], round(f["min_head_drop"], 9)
    (0.1, 1.0, 0.1)
    """
    speed, head = np.asarray(series["speed_rpm"]), np.asarray(series["head_m"])
    n0, h0 = float(speed[0]), float(head[0])
    return {
        **speed_figures(time_s, speed, rated_speed_rpm),
        "max_head_rise": float(head.max() / h0 - 1.0), "max_head_m": float(head.max()),
        "t_max_head_s": float(time_s[int(np.argmax(head))]),
        "min_head_drop": float(1.0 - head.min() / h0), "min_head_m": float(head.min()),
        "t_min_head_s": float(time_s[int(np.argmin(head))]),
        "final_speed_error": float((speed[-1] - series["speed_reference_rpm"]) / rated_speed_rpm),
        "initial_speed_rpm": n0, "initial_head_m": h0, "initial_flow_m3_s": float(series["flow_m3_s"][0]),
        "initial_opening": float(series["opening"][0]), "initial_power_mw": float(series["power_mw"][0]),
        "final_opening": float(series["opening"][-1]),
        "max_power_mw": float(np.max(series["power_mw"])), "min_power_mw": float(np.min(series["power_mw"])),
    }


def worst_over_units(units: dict) -> dict:
    """The plant-level figures of :data:`WORST_FIGURES` as the worst over ``units`` ({name: :func:`unit_figures`}),
    each with its time and ``<figure>_unit``, the unit that gives it.

    Examples
    --------
    >>> units = {"U1": {"max_speed_rise": 0.3, "t_max_speed_s": 5.0}, "U2": {"max_speed_rise": 0.01,
    ...                                                                     "t_max_speed_s": 3.0}}
    >>> {k: v for k, v in worst_over_units(units).items() if "speed_rise" in k}
    {'max_speed_rise': 0.3, 'max_speed_rise_unit': 'U1'}
    """
    out = {}
    for figure, (sense, time_key) in WORST_FIGURES.items():
        have = {name: fig for name, fig in units.items() if figure in fig}
        if not have:
            continue
        pick = (max if sense == "max" else min)(have, key=lambda name: have[name][figure])
        out[figure] = have[pick][figure]
        out[f"{figure}_unit"] = pick
        if time_key in have[pick]:
            out[time_key] = have[pick][time_key]
    return out


def unit_series(result, plant) -> list[tuple[str | None, dict, float]]:
    """``(unit name, series, runner diameter m)`` of every unit of ``plant`` in ``result`` (a
    :class:`SimulationResult`): each of a plant with several units with its own runner, else one entry ``(None,
    the plant-level series, the turbine's runner)``. Each ``series`` has ``speed_rpm``, ``head_m``, ``flow_m3_s``
    and ``opening_chart``."""
    if result.units:
        runners = {unit.name: unit.turbine.runner_diameter_m for unit in plant.units}
        return [(name, series, runners[name]) for name, series in result.units.items()]
    return [(None, {name: getattr(result, name) for name in ("speed_rpm", "head_m", "flow_m3_s", "opening_chart")},
             plant.turbine.runner_diameter_m)]


#: Columns of timeseries.csv, in order, with units.
CSV_COLUMNS = ("time_s", "speed_rpm", "head_m", "flow_m3_s", "opening", "opening_chart", "torque_nm", "power_mw",
               "iterations")


@dataclass(frozen=True)
class SimulationResult:
    """Time series of one run (one row per step, row 0 the verified initial state).

    Attributes
    ----------
    time_s, speed_rpm, head_m (at the turbine inlet), flow_m3_s, opening (stroke fraction), opening_chart (chart
    units), torque_nm (turbine), power_mw (turbine), iterations (pressure-loop iterations of the step, 0 in row 0)
        ndarray, shape (n_rows,)
    speed_reference_rpm : float
        Governor speed reference at the end (rated speed for open-loop kinds).
    success : bool
        False when the pressure loop failed and the caller asked for a result instead of an exception; the
        series then stop at the last good step and ``message`` says why.
    message : str
    meta : dict
        Run settings (penstock model, pressure loop, dt, steady-state residuals, ...).
    component_figures : dict
        The figures the plant's components give after the run (a surge tank's highest and lowest level, a draft
        tube's lowest outlet pressure, ...), also in ``meta``: what a batch case reports beside the turbine's.
    wall_time_s : float
        Wall-clock time of the time loop (not in the summary, which stays deterministic).
    """

    time_s: np.ndarray
    speed_rpm: np.ndarray
    head_m: np.ndarray
    flow_m3_s: np.ndarray
    opening: np.ndarray
    opening_chart: np.ndarray
    torque_nm: np.ndarray
    power_mw: np.ndarray
    iterations: np.ndarray
    speed_reference_rpm: float
    rated_speed_rpm: float
    success: bool = True
    message: str = "ok"
    meta: dict = field(default_factory=dict)
    wall_time_s: float = float("nan")
    signals: dict = field(default_factory=dict)
    envelope_x_m: np.ndarray | None = None
    envelope_max_m: np.ndarray | None = None
    envelope_min_m: np.ndarray | None = None
    steady: object = None
    plant: object = None
    characteristics: object = field(default=None, repr=False, compare=False)
    units: dict = field(default_factory=dict)
    junction: dict = field(default_factory=dict, repr=False, compare=False)
    component_figures: dict = field(default_factory=dict)

    def columns(self) -> dict[str, np.ndarray]:
        """The series by CSV column name: :data:`CSV_COLUMNS`, then the components' extra signals (e.g. a surge
        tank's ``surge_level_m``, ``tunnel_flow_m3_s``)."""
        out = {name: getattr(self, name) for name in CSV_COLUMNS}
        out.update(self.signals)
        for unit, series in self.units.items():  # a plant with several units: U1.speed_rpm, ...
            for name in UNIT_COLUMNS:
                out[f"{unit}.{name}"] = series[name]
        return out

    def summary(self) -> dict:
        """Summary figures (fractions of the initial values unless the name says otherwise).

        ``max_speed_rise`` max|n|/|n0| - 1 (the largest speed in either direction: :func:`speed_figures`),
        ``t_max_speed_s``, ``max_speed_rpm`` (that |n|); ``max_head_rise`` max(H)/H0 - 1; ``min_head_drop``
        1 - min(H)/H0; ``final_speed_error`` (n_end - n_ref)/n_rated with n_ref the final speed reference;
        ``max_head_m``/``min_head_m`` at the turbine (m) and when; the head envelope along the penstock
        (``envelope_*``; with a profile ``min_pressure_head_m`` and where, ``column_separation``);
        ``extrapolation`` (per kind of :mod:`simulate.loop.domain`: fraction of the time outside the trusted domain and
        the extremes reached); ``warnings`` (time step, extrapolation, column separation);
        ``mean_iterations``/``max_iterations`` over the steps (row 0 excluded; steps with the vanes shut count 0,
        there is nothing to solve); plus the initial point, success,
        message and the run settings from ``meta``.

        Examples
        --------
        >>> t = np.array([0.0, 1.0, 2.0])
        >>> r = SimulationResult(t, np.array([100.0, 110.0, 100.5]), np.array([50.0, 60.0, 45.0]), t, t, t, t, t,
        ...                      np.array([0, 2, 4]), speed_reference_rpm=100.0, rated_speed_rpm=100.0)
        >>> s = r.summary()
        >>> [round(s[k], 6) for k in ("max_speed_rise", "t_max_speed_s", "max_head_rise", "min_head_drop",
        ...                           "final_speed_error", "mean_iterations", "max_iterations")]
        [0.1, 1.0, 0.2, 0.1, 0.005, 3.0, 4]
        """
        n0, h0 = float(self.speed_rpm[0]), float(self.head_m[0])
        steps = self.iterations[1:]
        out = {
            **speed_figures(self.time_s, self.speed_rpm, self.rated_speed_rpm),
            "max_head_rise": float(self.head_m.max() / h0 - 1.0),
            "min_head_drop": float(1.0 - self.head_m.min() / h0),
            "final_speed_error": float((self.speed_rpm[-1] - self.speed_reference_rpm) / self.rated_speed_rpm),
            "mean_iterations": float(steps.mean()) if steps.size else 0.0,
            "max_iterations": int(steps.max()) if steps.size else 0,
            "t_max_head_s": float(self.time_s[int(np.argmax(self.head_m))]),
            "max_head_m": float(self.head_m.max()),
            "min_head_m": float(self.head_m.min()),
            "t_min_head_s": float(self.time_s[int(np.argmin(self.head_m))]),
            "initial_speed_rpm": n0,
            "initial_head_m": h0,
            "initial_flow_m3_s": float(self.flow_m3_s[0]),
            "initial_opening": float(self.opening[0]),
            "initial_power_mw": float(self.power_mw[0]),
            "final_opening": float(self.opening[-1]),
            "t_end_s": float(self.time_s[-1]),
            "steps": int(self.time_s.size - 1),
            "success": bool(self.success),
            "message": self.message,
        }
        out.update(self.meta)
        if self.units:
            out["units"] = {name: unit_figures(self.time_s, series, self.rated_speed_rpm)
                            | ({"extrapolation": series["extrapolation"]} if "extrapolation" in series else {})
                            for name, series in self.units.items()}
            out.update(worst_over_units(out["units"]))
        if self.envelope_max_m is not None:
            env = envelope_summary(self)
            out.update(env)
            extra = [w for w in envelope_warnings(env) if w not in out.get("warnings", [])]
            if extra:
                out["warnings"] = list(out.get("warnings", [])) + extra
        return out

    def to_csv(self, path: str | Path) -> Path:
        """Write timeseries.csv (header line with :data:`CSV_COLUMNS`, one row per step, 10 significant digits).

        Examples
        --------
        >>> import tempfile, pathlib
        >>> t = np.array([0.0, 0.5])
        >>> r = SimulationResult(t, t + 200, t + 100, t, t, t, t, t, np.array([0, 3]), 200.0, 200.0)
        >>> path = r.to_csv(pathlib.Path(tempfile.mkdtemp()) / "timeseries.csv")
        >>> path.read_text().splitlines()[:2]  # doctest: +NORMALIZE_WHITESPACE
        ['time_s,speed_rpm,head_m,flow_m3_s,opening,opening_chart,torque_nm,power_mw,iterations',
         '0,200,100,0,0,0,0,0,0']
        """
        path = Path(path)
        columns = self.columns()
        names = list(columns)
        data = np.column_stack([columns[c] for c in names])
        fmt = ["%.10g" if c != "iterations" else "%d" for c in names]
        np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt=fmt)
        return path

    def to_json(self, path: str | Path, *, series: bool = False) -> Path:
        """Write the :meth:`summary` as JSON (summary.json); with ``series=True`` also every column of
        timeseries.csv under ``"series"`` (``{column: [values]}``, full precision). Summary floats are tidied
        (:func:`hillchart.io.tidy.tidy_floats`: 12 significant digits, |x| < 1e-30 written as 0)."""
        from hillchart.io.tidy import tidy_floats

        path = Path(path)
        summary = tidy_floats(json.loads(json.dumps(self.summary(), default=json_default)))
        data = summary | ({"series": self.columns()} if series else {})
        path.write_text(json.dumps(data, indent=2, sort_keys=True, default=json_default) + "\n",
                        encoding="utf-8")
        return path

    def guarantee_marks(self, band=None) -> list[dict]:
        """What :meth:`plot` marks for each guarantee figure: ``figure`` (summary name), ``trace`` (the series it
        is read on), ``time_s``, ``value`` (in the trace's unit), ``band`` (``(low, high)`` in that unit, or None
        without a band for it), ``share`` (``(kind, fraction)`` of :func:`extrapolation_share`, or None) and the
        annotation ``text``."""
        marks = []
        record = self.meta.get("extrapolation")
        figures_band = getattr(band, "figures", None) or {}
        for figure, trace, label, sign in GUARANTEE_FIGURES:
            values = getattr(self, trace)
            i = extremum_index(trace, values, sign)
            v0, value = float(values[0]), float(values[i])
            if trace == "speed_rpm":  # the summary's figure (speed_figures): the largest |n| over |n0| (n_r at rest)
                value, v0 = abs(value), speed_base_rpm(v0, self.rated_speed_rpm)
            rise = sign * (value / v0 - 1.0)  # the summary's figure: max(x)/x0 - 1, or 1 - min(x)/x0
            unit = "r/min" if trace == "speed_rpm" else "m"
            text = f"{label} {value:.1f} {unit} ({'+' if sign > 0 else '-'}{100 * rise:.2f} %)"
            limits = None
            if figure in figures_band:
                low, high = (v0 * (1.0 + sign * f) for f in figures_band[figure])
                limits = (min(low, high), max(low, high))
                text += f"\nband {limits[0]:.1f}-{limits[1]:.1f} {unit}"
            share = extrapolation_share(record, figure)
            if share is not None:
                where = "the digitized chart" if share[0] == "digitized_region" else "the nets' training range"
                text += f"\n{100 * share[1]:.0f} % of the run up to it outside {where}"
            marks.append({"figure": figure, "trace": trace, "time_s": float(self.time_s[i]), "value": value,
                          "band": limits, "share": share, "text": text})
        return marks

    def plot(self, path: str | Path | None = None, band=None):
        """Speed, head, flow and opening against time (like paper 004 Fig. 11); saved when ``path`` is given.

        Intervals where the trajectory leaves the characteristics' trusted domain (``meta["extrapolation"]``) are
        shaded. ``band``: a :class:`simulate.studies.uncertainty.TraceBand` (``hillsim run --uncertainty``), drawn as
        the ensemble's percentile band behind each trace it covers. Each guarantee figure (max speed rise, max head
        rise, min head) is marked where it comes and annotated with its value, its band (an error bar, with
        ``band``) and its extrapolation share (the share of the run up to it spent outside the digitized chart,
        ``meta["extrapolation"]["figures"]``); see :meth:`guarantee_marks`. Uses matplotlib's object API with the Agg
        canvas (no pyplot, no display; imported here, not with the module). Returns the figure.
        """
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        series = ((self.speed_rpm, "speed (r/min)", "speed_rpm"), (self.head_m, "head at turbine (m)", "head_m"),
                  (self.flow_m3_s, "flow (m$^3$/s)", "flow_m3_s"), (self.opening, "opening (stroke)", "opening"))
        if "frequency_hz" in self.signals:  # the sub-transient generator: frequency for speed, plus V and v_f
            series = (((self.signals["frequency_hz"], "frequency (Hz)", None),) + series[1:]
                      + ((self.signals["terminal_voltage_pu"], "terminal voltage (pu)", None),
                         (self.signals["field_voltage_pu"], "field voltage (pu)", None)))
        if "blade_angle_deg" in self.signals:  # a double-regulated unit: the blades and what the cam asks
            series = series + ((self.signals["blade_angle_deg"], "blade angle (deg)", None),)
        if "draft_tube_head_m" in self.signals:  # the head at the runner outlet
            series = series + ((self.signals["draft_tube_head_m"], "draft tube head (m)", None),)
        fig = Figure(figsize=(8, 9 if len(series) == 4 else 12))
        FigureCanvasAgg(fig)
        axes = fig.subplots(len(series), 1, sharex=True)
        intervals = (self.meta.get("extrapolation") or {}).get("intervals_s", [])
        banded = False
        for ax, (values, label, name) in zip(axes, series):
            if band is not None and name in band.low:
                low, high = band.percentiles
                ax.fill_between(band.time_s, band.low[name], band.high[name], color="tab:orange", alpha=0.35, lw=0,
                                label=None if banded else f"ensemble of {band.members}, {low:g}-{high:g} %")
                banded = True
            if self.units and name in UNIT_COLUMNS:  # a plant with several units: one trace per unit
                for unit, unit_series in self.units.items():
                    ax.plot(self.time_s, unit_series[name], lw=1.2, label=unit)
            else:
                ax.plot(self.time_s, values, lw=1.2,
                        label="point nets" if band is not None and ax is axes[0] else None)
            if label == "blade angle (deg)":
                ax.plot(self.time_s, self.signals["blade_angle_cam_deg"], lw=1.0, ls="--", label="cam")
                ax.legend(loc="best", fontsize=8)
            ax.set_ylabel(label)
            ax.grid(True, alpha=0.3)
            for i, (t0, t1) in enumerate(intervals):
                ax.axvspan(t0, t1, color="tab:red", alpha=0.12, lw=0,
                           label=EXTRAPOLATED_LABEL if i == 0 and ax is axes[0] else None)
        on_axes = {"speed_rpm": axes[0] if series[0][2] == "speed_rpm" else None, "head_m": axes[1]}
        for mark in self.guarantee_marks(band):
            ax = on_axes[mark["trace"]]
            if ax is None:
                continue
            t, value = mark["time_s"], mark["value"]
            if mark["band"] is not None:
                low, high = mark["band"]
                bar = ax.errorbar([t], [value], yerr=[[max(value - low, 0.0)], [max(high - value, 0.0)]],
                                  fmt="none", ecolor="tab:orange", elinewidth=2.0, capsize=4)
                for artist in bar.lines[2]:  # the vertical bar (a LineCollection): named for readers of the figure
                    artist.set_gid(f"guarantee-band:{mark['figure']}")
            ax.plot([t], [value], "v" if mark["figure"] != "min_head_drop" else "^", color="k", ms=5,
                    gid=f"guarantee:{mark['figure']}")
            right = t > 0.6 * float(self.time_s[-1])  # text to the left of late points, so it stays inside the axes
            below = mark["figure"] != "min_head_drop"
            ax.annotate(mark["text"], (t, value), xytext=(-8 if right else 8, -16 if below else 6),
                        textcoords="offset points", fontsize=7, ha="right" if right else "left",
                        va="top" if below else "bottom", gid=f"guarantee:{mark['figure']}",
                        bbox={"boxstyle": "round,pad=0.2", "fc": "white", "alpha": 0.8, "lw": 0})
        if intervals or banded or self.units:
            axes[0].legend(loc="best", fontsize=8)
        axes[-1].set_xlabel("time (s)")
        title = self.meta.get("scenario", "")
        fig.suptitle(f"{title}  penstock {self.meta.get('penstock_model', '')}, pressure loop "
                     f"{self.meta.get('pressure_loop', '')}" + ("" if self.success else "  (FAILED)"))
        # fixed margins (what tight_layout finds for these labels) instead of tight_layout, which draws the figure
        # once more to measure the text: about a third of the figure's time
        fig.subplots_adjust(left=0.095, right=0.98, bottom=0.065, top=0.945, hspace=0.1)
        if path is not None:
            save_png(fig, path)
        return fig


#: The guarantee figures marked on transient.png: (summary name, trace, label, sign of the rise).
GUARANTEE_FIGURES = (("max_speed_rise", "speed_rpm", "max speed", 1.0), ("max_head_rise", "head_m", "max head", 1.0),
                     ("min_head_drop", "head_m", "min head", -1.0))


def extrapolation_share(record: dict | None, figure: str) -> tuple[str, float] | None:
    """``(kind, share)`` of a guarantee figure from a run's extrapolation record (``summary["extrapolation"]``):
    the share of the run up to the figure spent outside the digitized region of the chart (outside the nets'
    training range when the digitized region is not known); None when the record has neither.

    Examples
    --------
    >>> extrapolation_share({"figures": {"max_head_rise": {"time_s": 9.0, "digitized_region": 0.25,
    ...                                                    "full_stroke": 0.0}}}, "max_head_rise")
    ('digitized_region', 0.25)
    >>> extrapolation_share({"figures": {}}, "max_head_rise") is None
    True
    """
    entry = ((record or {}).get("figures") or {}).get(figure) or {}
    for kind in ("digitized_region", "training_range"):
        if kind in entry:
            return kind, float(entry[kind])
    return None


def json_default(value):
    """``json.dumps(default=...)`` for numpy scalars and arrays, complex numbers ([re, im]) and paths; anything
    else is a TypeError (never silently stringified)."""
    if isinstance(value, complex):
        return [value.real, value.imag]
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"not JSON serializable: {type(value).__name__}")
