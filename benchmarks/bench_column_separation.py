"""Water-column separation on the Bergant-Simpson laboratory rig: the discrete vapour and gas cavity models against
the pressure peaks measured at the valve.

    PYTHONPATH=$PWD python benchmarks/bench_column_separation.py [--figures DIR]

The rig (Bergant and Simpson, "Pipeline column separation flow regimes", J. Hydraul. Eng. 125(8), 835-848, 1999;
Bergant, Simpson and Tijsseling, J. Fluids Struct. 22, 2006), University of Adelaide: a copper pipe of L = 37.23 m,
D = 22.1 mm (wall 1.63 mm), a = 1319 m/s, rising 2.03 m (slope 5.45 %) from the upstream tank to a ball valve at
its downstream end, shut in 9 ms from steady flow at V0 = 0.3 m/s and 1.4 m/s. The settings are those of the rig's
validation data in RTHYM-MOC (github.com/jlillywh/RTHYM-MOC, validation/datasets/bergant_adelaide/
moderate_reference.json and severe_reference.json, commit 7fa6c23bebbd97cce0de3c2409ca04c1cc8e222d, which cite
Bergant and Simpson 1999 and He, Li and Guo, "Modeling transient vaporous cavitating flow in pipelines by a
two-phase homogeneous flow model", Processes 13(11), 3510, 2025, Table 1 and Figs. 3-4): the upstream tank's head
22 m above the pipe's upstream end for both velocities (19.97 m above the valve), the pipe rising toward the valve
(upward-sloping, elevation difference 2.03 m). The papers themselves could not be read here (only their abstracts
and the conclusions of He et al. at mdpi.com/2227-9717/13/11/3510); the tank head is taken from that data set.

The figures held (:data:`MEASURED`, absolute pressure at the valve, kPa) are both peaks of a cavity's collapse, not
the water hammer of the closure: at 0.3 m/s 1015 kPa is the largest pressure measured at the valve (He et al., Fig. 3
and their conclusions, which give it as the measured maximum pressure peak; the data set's "maximum_absolute_kPa"),
above the Joukowsky peak of the closure (about 693 kPa with the tank at 22 m): the short pulse when the valve's first
cavity collapses. At 1.4 m/s 2057 kPa is the peak after the first cavity at the valve collapses (He et al., Fig. 4;
the data set's "second_peak_after_cavity_absolute_kPa", in its window 0.33-0.47 s), the water hammer of the closure
(about 2140 kPa) being the first. Neither source gives the peaks' times as numbers.

Here the valve is the ideal turbine at full stroke (Q = Q0 sqrt(H / H0)) shut linearly by the closure-law scenario;
its outlet datum (the "tailwater") lies :data:`VALVE_ELEVATION_M` below the valve, so that the net head of the shut
valve stays positive at the vapour head. The Darcy friction factor is Blasius's smooth-pipe 0.316 / Re^0.25 at the
initial velocity (water at 20 degC: the vapour pressure 2.34 kPa; the rig's water temperature is not in the data
set, and 15 degC would move the vapour pressure by 0.6 kPa).

Prints, for each velocity, friction model, cavity model and step (dt, dt/2: 256 and 512 reaches, :data:`REACHES`):
the first peak at the valve, the time its first cavity collapsed (the cavity volume's linear extrapolation to zero
between the last two steps it was open, not the step index) and the largest pressure within 2 L / a after that (the
collapse peak) with its time, then the collapse peaks beside the figures held, the pulses of the measured trace, and
the defaults (the penstock's: the convolution friction and the discrete gas cavity model) on grids of 32 to 1024
reaches. ``--figures DIR`` draws the valve pressure over 0.5 s (``column_separation.png``).
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hillchart.constants import G_M_S2, RHO_WATER_KG_M3
from simulate.config import (GeneratorConfig, GovernorConfig, PenstockConfig, PenstockSegment, PlantConfig,
                             ScenarioConfig, SolverConfig, TurbineConfig)
from simulate.loop.engine import run_simulation

LENGTH_M, DIAMETER_M, WAVE_SPEED_M_S = 37.23, 0.0221, 1319.0
RISE_M = 2.03  # the valve above the pipe's upstream end (slope 5.45 %)
#: The upstream tank's head above the pipe's upstream end, m (RTHYM-MOC's data set, "upstream_head_m": 22.0).
TANK_HEAD_M = 22.0
CLOSING_TIME_S = 0.009
#: The valve above the datum of the heads (its outlet), m: more than the atmospheric head, so that the vapour head
#: at the valve (12 - 10.33 + 0.24 = 1.9 m) stays above the turbine boundary's head floor.
VALVE_ELEVATION_M = 12.0
EVENT_TIME_S = 0.01
WATER_VISCOSITY_M2_S = 1.0e-6
#: Absolute pressure at the valve held for the rig, kPa, by initial velocity: the peak of the first collapse of the
#: valve's cavity (at 0.3 m/s the largest of the run).
MEASURED = {0.3: 1015.0, 1.4: 2057.0}
#: The cavity models compared.
MODELS = ("dvcm", "dgcm")
#: The runs the figure draws (friction, cavity model): the defaults (the convolution and the DGCM) first.
FIGURE_RUNS = (("convolution", "dgcm"), ("convolution", "dvcm"), ("steady", "dvcm"))
#: The grid of the runs, MOC reaches (dt = L / (a reaches) = 0.110 ms), and twice as many for dt/2: from 256 reaches
#: the defaults' collapse peak at 1.4 m/s moves by less than 1 % with the step (:func:`grid_scan`); on coarser grids
#: a spike of one step, where cavities along the pipe collapse together, moves it by up to 7 %.
REACHES = 256
#: The grids of :func:`grid_scan`.
SCAN_REACHES = (32, 64, 128, 256, 512, 1024)


def blasius_friction(velocity_m_s: float) -> float:
    """Darcy friction factor of a smooth pipe, 0.316 Re^-0.25 (Blasius)."""
    return 0.316 / (velocity_m_s * DIAMETER_M / WATER_VISCOSITY_M2_S) ** 0.25


def rig_plant(velocity_m_s: float, *, friction_model: str | None = None, reaches: int = REACHES,
              column_separation: str | None = None, t_end_s: float = 0.5,
              tank_head_m: float = TANK_HEAD_M) -> PlantConfig:
    """The rig at initial velocity ``velocity_m_s`` with ``reaches`` MOC reaches (dt = L / (a reaches)) and the tank
    ``tank_head_m`` above the pipe's upstream end; the friction and cavity models the penstock's defaults unless
    given."""
    area = math.pi * DIAMETER_M ** 2 / 4.0
    flow = velocity_m_s * area
    f = blasius_friction(velocity_m_s)
    static = VALVE_ELEVATION_M - RISE_M + tank_head_m
    loss = f * LENGTH_M / DIAMETER_M * velocity_m_s ** 2 / (2.0 * G_M_S2)
    net = static - loss  # the valve's steady head: the ideal turbine at full stroke passes Q0 there
    turbine = TurbineConfig(rated_head_m=net, rated_flow_m3_s=flow, rated_speed_rpm=1500.0,
                            rated_power_mw=RHO_WATER_KG_M3 * G_M_S2 * flow * net * 1e-6, runner_diameter_m=0.02,
                            opening_max=1.0, characteristics="ideal")
    seg = PenstockSegment(length_m=LENGTH_M, diameter_m=DIAMETER_M, wave_speed_m_s=WAVE_SPEED_M_S, darcy_friction=f,
                          elevation_start_m=VALVE_ELEVATION_M - RISE_M, elevation_end_m=VALVE_ELEVATION_M)
    models = {key: value for key, value in (("friction_model", friction_model),
                                            ("column_separation", column_separation)) if value is not None}
    penstock = PenstockConfig(model="moc", static_head_m=static, reaches=reaches, segments=(seg,), **models)
    governor = GovernorConfig(kp=2.0, ki=0.5, kd=0.0, derivative_filter_s=0.0, permanent_droop=0.0, servo_time_s=0.2,
                              closing_time_s=10.0, opening_time_s=20.0)
    scenario = ScenarioConfig(kind="closure-law", t_end_s=t_end_s, initial_opening=1.0, event_time_s=EVENT_TIME_S,
                              closing_time_s=CLOSING_TIME_S)
    return PlantConfig(turbine=turbine, penstock=penstock, generator=GeneratorConfig(inertia_time_s=8.0),
                       governor=governor, scenario=scenario, solver=SolverConfig())


def valve_pressure_kpa(result) -> np.ndarray:
    """Absolute pressure at the valve, kPa: (H - z + H_atm) rho g."""
    atmospheric = result.meta["atmospheric_pressure_head_m"]
    return (result.head_m - VALVE_ELEVATION_M + atmospheric) * RHO_WATER_KG_M3 * G_M_S2 / 1e3


@dataclass(frozen=True)
class Peaks:
    """The first pressure peak at the valve, the time its first cavity collapsed and the largest pressure after that
    (kPa, and s after the start of the closure)."""

    first_kpa: float
    first_t_s: float
    cavity_closed_t_s: float
    collapse_kpa: float
    collapse_t_s: float
    max_cavity_m3: float


def cavity_closed_s(time_s: np.ndarray, volume_m3: np.ndarray, closed: int) -> float:
    """The time the cavity volume reaches zero, extrapolated linearly from its last two values before step
    ``closed`` (the first step without the cavity): t_last + dt V_last / (V_before - V_last), within the step.

    >>> cavity_closed_s(np.array([0.0, 1.0, 2.0, 3.0]), np.array([0.0, 3.0, 1.0, 0.0]), 3)   # 3 - 2 per step: 2.5
    2.5
    """
    last, before = volume_m3[closed - 1], volume_m3[closed - 2]
    dt = time_s[closed] - time_s[closed - 1]
    fraction = last / (before - last) if before > last else 1.0
    return float(time_s[closed - 1] + dt * min(fraction, 1.0))


def peaks(result) -> Peaks:
    """:class:`Peaks` of a rig run: the first peak is the largest pressure before the valve's cavity first opens;
    the collapse time that of :func:`cavity_closed_s`; the collapse peak the largest within 2 L / a after the
    valve's first cavity closed (NaN without a cavity at the valve)."""
    p = valve_pressure_kpa(result)
    t = result.time_s - EVENT_TIME_S
    cavity = result.signals["outlet_cavity_volume_m3"] if "outlet_cavity_volume_m3" in result.signals else None
    opened = np.flatnonzero(cavity > 0.0) if cavity is not None else np.array([], dtype=int)
    first_end = opened[0] if opened.size else p.size
    i = int(np.argmax(p[:first_end]))
    if opened.size:
        closed = opened[0] + int(np.argmax(cavity[opened[0]:] <= 0.0))
        window = (t >= t[closed]) & (t <= t[closed] + 2.0 * LENGTH_M / WAVE_SPEED_M_S)
        j = int(np.flatnonzero(window)[np.argmax(p[window])])
        closed_t, collapse, t_collapse = cavity_closed_s(t, cavity, closed), float(p[j]), float(t[j])
    else:
        closed_t = collapse = t_collapse = float("nan")
    return Peaks(float(p[i]), float(t[i]), closed_t, collapse, t_collapse,
                 float(result.summary().get("max_cavity_volume_m3", 0.0)))


#: The measured valve pressure at 1.4 m/s (absolute, kPa, against s from the start of the closure), digitized from
#: He et al. (2025), Fig. 4, for RTHYM-MOC (MIT licence); the file's header gives provenance and licence.
TRACE_PATH = Path(__file__).resolve().parent / "data" / "bergant_simpson_valve_trace_1p4.csv"
#: Windows (s after the start of the closure) of the three pressure pulses at the valve at 1.4 m/s: the closure's
#: water hammer, the collapse of the valve's first cavity and that of its second.
TRACE_WINDOWS = {"water hammer": (0.0, 0.1), "first collapse": (0.25, 0.5), "second collapse": (0.55, 0.8)}
#: A pulse's time: when the pressure first rises through this level in its window, kPa (half-way up the pulses; the
#: time of the largest pressure on a pulse's ragged top is not a robust figure).
PULSE_LEVEL_KPA = 1000.0
#: The runs the trace is compared with (friction, cavity model), to 0.85 s.
TRACE_RUNS = (("steady", "dvcm"), ("convolution", "dvcm"), ("convolution", "dgcm"))
TRACE_END_S = 0.85


#: Points of the file that are not the measured curve: from 0.446 to 0.477 s six points at 2061.7-2062.0 kPa, equally
#: spaced (6.5 ms), where the curve has fallen to the cavity's pressure at 0.443 s: the digitizer followed a
#: horizontal line of the figure (the peak's annotation, 2057 kPa). Box (t_lo, t_hi, p_lo, p_hi), s and kPa.
TRACE_EXCLUDED = (0.445, 0.478, 2061.0, 2063.0)


def measured_trace() -> tuple[np.ndarray, np.ndarray]:
    """The digitized valve pressure at 1.4 m/s without :data:`TRACE_EXCLUDED`: times (s after the start of the
    closure, as the figure gives them) and absolute pressure (kPa), in time order. The digitization reads the
    cavity's pressure as -10 to -30 kPa (absolute: its offset, about 1.5 % of the peaks)."""
    rows = [line.split(",") for line in TRACE_PATH.read_text(encoding="utf-8").splitlines()
            if line and not line.startswith("#") and line[0].isdigit()]  # the data lines (not the column names)
    values = np.array(rows, dtype=float)
    t_lo, t_hi, p_lo, p_hi = TRACE_EXCLUDED
    values = values[~((values[:, 0] >= t_lo) & (values[:, 0] <= t_hi) & (values[:, 1] >= p_lo)
                      & (values[:, 1] <= p_hi))]
    order = np.argsort(values[:, 0], kind="stable")
    return values[order, 0], values[order, 1]


def window_peaks(time_s, pressure_kpa) -> dict:
    """Each pulse of :data:`TRACE_WINDOWS`: its largest pressure (kPa) and the time it rises through
    :data:`PULSE_LEVEL_KPA` (s: the first sample in the window at or above it whose predecessor is below; NaN when
    it does not rise through it there)."""
    out = {}
    for name, (lo, hi) in TRACE_WINDOWS.items():
        inside = np.flatnonzero((time_s >= lo) & (time_s < hi))
        rising = inside[(inside > 0) & (pressure_kpa[inside] >= PULSE_LEVEL_KPA)]
        rising = rising[pressure_kpa[rising - 1] < PULSE_LEVEL_KPA]
        out[name] = (float(pressure_kpa[inside].max()), float(time_s[rising[0]]) if rising.size else float("nan"))
    return out


def trace_table(reaches: int = REACHES, runs=TRACE_RUNS, label: str = "") -> list[dict]:
    """The peaks of :data:`TRACE_WINDOWS` measured and computed at 1.4 m/s (each of ``runs``, (friction, cavity
    model), at dt and dt / 2; ``label`` before each computed run's name)."""
    rows = [{"run": "measured", "dt_s": float("nan"), "peaks": window_peaks(*measured_trace())}]
    for friction, model in runs:
        for n in (reaches, 2 * reaches):
            r = run_simulation(rig_plant(1.4, friction_model=friction, reaches=n, column_separation=model,
                                         t_end_s=TRACE_END_S))
            rows.append({"run": f"{label}{model.upper()}, {friction} friction", "dt_s": r.meta["dt_s"],
                         "peaks": window_peaks(r.time_s - EVENT_TIME_S, valve_pressure_kpa(r)), "result": r})
    return rows


def trace_markdown(rows: list[dict]) -> str:
    """:func:`trace_table` as a markdown table, each computed figure with its difference from the measured one."""
    measured = rows[0]["peaks"]
    head = "| run | dt (ms) | " + " | ".join(f"{name}: peak (kPa), rises at (ms)" for name in TRACE_WINDOWS) + " |"
    lines = [head, "|---|---|" + "---|" * len(TRACE_WINDOWS)]
    for row in rows:
        cells = []
        for name in TRACE_WINDOWS:
            (p, t), (p0, t0) = row["peaks"][name], measured[name]
            if row is rows[0]:
                cells.append(f"{p:.0f}, {1e3 * t:.1f}")
            else:
                # the water hammer's rise, a few ms after the start of the closure: its difference in ms (in per
                # cent of so short a time it would mostly say where each source put the closure's start)
                when = (f"{1e3 * (t - t0):+.1f} ms" if name == "water hammer" else f"{100 * (t / t0 - 1):+.1f} %")
                when = "none" if math.isnan(t) else when
                cells.append(f"{p:.0f} ({100 * (p / p0 - 1):+.1f} %), {1e3 * t:.1f} ({when})")
        dt = "-" if row is rows[0] else f"{1e3 * row['dt_s']:.4f}"
        lines.append(f"| {row['run']} | {dt} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def table(velocities=(0.3, 1.4), frictions=("steady", "brunone", "convolution"), models=MODELS,
          reaches: int = REACHES, tank_head_m: float = TANK_HEAD_M) -> list[dict]:
    """One row per velocity, friction model, cavity model and step (dt, dt/2)."""
    rows = []
    for v in velocities:
        for friction in frictions:
            for model in models:
                for n in (reaches, 2 * reaches):
                    r = run_simulation(rig_plant(v, friction_model=friction, reaches=n, column_separation=model,
                                                 tank_head_m=tank_head_m))
                    rows.append({"velocity_m_s": v, "friction": friction, "model": model, "dt_s": r.meta["dt_s"],
                                 "peaks": peaks(r), "result": r})
    return rows


def grid_scan(reaches=SCAN_REACHES) -> list[dict]:
    """The defaults on each grid of ``reaches``: the collapse peak at both velocities and, at 1.4 m/s, the time the
    first collapse's pulse rises through :data:`PULSE_LEVEL_KPA` (s after the start of the closure)."""
    rows = []
    for n in reaches:
        row = {"reaches": n}
        for v in MEASURED:
            r = run_simulation(rig_plant(v, reaches=n, t_end_s=TRACE_END_S if v > 1.0 else 0.5))
            row["dt_s"] = r.meta["dt_s"]
            row[v] = peaks(r).collapse_kpa
            if v > 1.0:
                row["rise_s"] = window_peaks(r.time_s - EVENT_TIME_S, valve_pressure_kpa(r))["first collapse"][1]
        rows.append(row)
    return rows


def grid_scan_markdown(rows: list[dict]) -> str:
    """:func:`grid_scan` as a markdown table, each figure beside the measured one and the last column the change of
    the 1.4 m/s peak from the grid before (half as many reaches)."""
    rise = window_peaks(*measured_trace())["first collapse"][1]
    lines = ["| reaches | dt (ms) | collapse peak at 0.3 m/s (kPa) | collapse peak at 1.4 m/s (kPa) | "
             "first collapse rises at (ms) | 1.4 m/s peak against the grid with half the reaches |",
             "|---|---|---|---|---|---|"]
    for i, row in enumerate(rows):
        before = rows[i - 1] if i and rows[i - 1]["reaches"] * 2 == row["reaches"] else None
        change = f"{100 * (row[1.4] / before[1.4] - 1):+.1f} %" if before else "-"
        lines.append(f"| {row['reaches']} | {1e3 * row['dt_s']:.4f} | {row[0.3]:.0f} "
                     f"({100 * (row[0.3] / MEASURED[0.3] - 1):+.1f} %) | {row[1.4]:.0f} "
                     f"({100 * (row[1.4] / MEASURED[1.4] - 1):+.1f} %) | {1e3 * row['rise_s']:.1f} "
                     f"({100 * (row['rise_s'] / rise - 1):+.1f} %) | {change} |")
    return "\n".join(lines)


def figure(rows, path: Path) -> Path:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 5.5))
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, 1, sharex=True)
    for ax, v in zip(axes, (0.3, 1.4)):
        for row in rows:
            if row["velocity_m_s"] == v and (row["friction"], row["model"]) in FIGURE_RUNS and row["dt_s"] == max(
                    r["dt_s"] for r in rows if r["velocity_m_s"] == v):
                r, p = row["result"], row["peaks"]
                line, = ax.plot(r.time_s - EVENT_TIME_S, valve_pressure_kpa(r), lw=1,
                                label=f"{row['model'].upper()}, {row['friction']} friction")
                ax.plot(p.collapse_t_s, p.collapse_kpa, "o", mfc="none", color=line.get_color(), ms=6)
        ax.axhline(MEASURED[v], color="k", ls=":", lw=1, label=f"held collapse peak {MEASURED[v]:g} kPa (measured)")
        if v == 1.4:
            t_m, p_m = measured_trace()
            keep = t_m <= max(r.time_s[-1] - EVENT_TIME_S for r in (row["result"] for row in rows))
            ax.plot(t_m[keep], p_m[keep], ".", color="k", ms=2, label="measured (digitized, He et al. 2025 Fig. 4)")
        ax.set_ylabel("absolute pressure at the valve (kPa)")
        ax.set_title(f"V0 = {v} m/s", fontsize=10)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper left" if v < 1.0 else "center", fontsize=8)
    axes[-1].set_xlabel("time after the start of the closure (s)")
    fig.subplots_adjust(left=0.11, right=0.98, bottom=0.09, top=0.95, hspace=0.25)
    from simulate.results.figures import save_png

    save_png(fig, path)
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--figures", type=Path, help="folder for column_separation.png")
    parser.add_argument("--tank-head", type=float, default=TANK_HEAD_M,
                        help="the upstream tank's head above the pipe's upstream end, m (default %(default)s)")
    args = parser.parse_args(argv)
    print(f"tank head {args.tank_head:g} m above the pipe's upstream end")
    rows = table(tank_head_m=args.tank_head)
    print("| V0 (m/s) | friction | model | dt (ms) | first peak (kPa) | at (ms) | cavity closed (ms) | "
          "collapse peak (kPa) | at (ms) | largest cavity (mm^3) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for row in rows:
        p = row["peaks"]
        print(f"| {row['velocity_m_s']} | {row['friction']} | {row['model']} | {1e3 * row['dt_s']:.4f} | "
              f"{p.first_kpa:.0f} | {1e3 * p.first_t_s:.2f} | {1e3 * p.cavity_closed_t_s:.2f} | "
              f"{p.collapse_kpa:.0f} | {1e3 * p.collapse_t_s:.2f} | {1e9 * p.max_cavity_m3:.1f} |")
    print()
    print("| V0 (m/s) | held collapse peak (kPa) | friction | model | computed, dt / dt/2 (kPa) | difference |")
    print("|---|---|---|---|---|---|")
    for v, held in MEASURED.items():
        for friction in dict.fromkeys(r["friction"] for r in rows):
            for model in MODELS:
                pair = [r["peaks"].collapse_kpa for r in rows if r["velocity_m_s"] == v
                        and r["friction"] == friction and r["model"] == model]
                print(f"| {v} | {held:g} | {friction} | {model} | {pair[0]:.0f} / {pair[1]:.0f} | "
                      f"{100 * (pair[0] / held - 1):+.1f} / {100 * (pair[1] / held - 1):+.1f} % |")
    print()
    print(f"The measured trace at 1.4 m/s ({TRACE_PATH.name}): each pulse's largest pressure and the time it rises "
          f"through {PULSE_LEVEL_KPA:g} kPa, to {TRACE_END_S:g} s")
    print()
    print(trace_markdown(trace_table()))
    print()
    print("The defaults (the convolution friction, the DGCM) on each grid: the collapse peaks against those held "
          f"({MEASURED[0.3]:g} and {MEASURED[1.4]:g} kPa) and the first collapse's rise against the trace's")
    print()
    print(grid_scan_markdown(grid_scan()))
    if args.figures is not None:
        args.figures.mkdir(parents=True, exist_ok=True)
        print(figure(rows, args.figures / "column_separation.png"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
