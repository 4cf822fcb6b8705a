"""The chart of ``hillsim report`` with each load case's path on it: the hill chart (iso-efficiency contours over
N11, Q11) of a turbine's characteristics, or the Suter curves WH(x) and WM(x) of characteristics over all four
quadrants, whose kind says so (:attr:`simulate.components.turbine.kinds.CharacteristicKind.four_quadrant`); an
iso-efficiency contour means nothing where the flow or the speed reverses."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

#: Angles of the drawn Suter curves over [0, 2 pi) (0.5 deg), and the most opening lines drawn.
CURVE_ANGLES = 720
MAX_OPENING_LINES = 6


def plot_operating_chart(chars, plant, runs, path: Path, *, four_quadrant: bool) -> str:
    """Draw the chart of ``chars`` (as the plant sees them) with each run ``(name, SimulationResult)`` into
    ``path`` and return its caption: the Suter curves (:func:`plot_suter_curves_with_runs`) when
    ``four_quadrant``, else the hill chart (:func:`plot_hill_chart_with_runs`)."""
    if four_quadrant:
        plot_suter_curves_with_runs(chars, plant, runs, path)
        return ("Suter curves WH(x) and WM(x) of the four-quadrant characteristics at the openings the runs held, "
                "with each run's path (x = pi + atan2(q + k2 sqrt(h), v); the quadrants at x = pi/2, pi, 3 pi/2)")
    plot_hill_chart_with_runs(chars, plant, runs, path)
    return "iso-efficiency contours of the characteristics with each run's (N11, Q11) path"


def trajectories(plant, runs) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """``(label, N11, Q11)`` of each run ``(name, SimulationResult)`` on the hill chart: N11 = n D1 / sqrt(H),
    Q11 = Q / (D1^2 sqrt(H)); every unit of a plant with several, each on its own runner (the plant-level series
    are one unit's)."""
    from simulate.results.result import unit_series

    from hillchart.characteristics import unit_quantities

    out = []
    for name, result in runs:
        for unit, s, d1 in unit_series(result, plant):
            n11, q11 = unit_quantities(s["speed_rpm"], s["flow_m3_s"], np.maximum(s["head_m"], 1e-9), d1)
            out.append((name if unit is None else f"{name}, {unit}", n11, q11))
    return out


def plot_hill_chart_with_runs(chars, plant, runs, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from hillchart.nets.chartplot import plot_hill_chart

    traj = trajectories(plant, runs)
    n_all = np.concatenate([n for _, n, _ in traj])
    flow = getattr(chars, "flow", None)
    if flow is not None:
        n11_range = (max(1e-3, float(flow.x_min[0]), 0.05 * float(flow.x_max[0])), float(flow.x_max[0]))
        opening_range = (float(flow.x_min[1]), float(flow.x_max[1]))
    else:
        n11_range = (max(1e-3, 0.8 * float(n_all.min())), 1.1 * float(n_all.max()))
        opening_range = (0.0, plant.turbine.opening_max)
    fig, ax = plt.subplots(figsize=(9, 7))
    plot_hill_chart(chars, ax, n11_range=n11_range, opening_range=opening_range, grid=161,
                    title="hill chart with the operating range of each load case")
    for name, n11, q11 in traj:
        line, = ax.plot(n11, q11, lw=1.6, label=f"{name}: N11 {n11.min():.1f}-{n11.max():.1f} r/min")
        ax.plot(n11[0], q11[0], "o", color=line.get_color())
    ax.legend(loc="upper left", fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def suter_paths(chars, plant, runs) -> list[tuple[str, np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """``(label, x, WH, WM, y)`` of each run on the Suter curves of ``chars``
    (:class:`simulate.components.turbine.four_quadrant.SuterCharacteristics`): its relative speed, flow, head and
    torque on the bases of the rated unit point (:func:`simulate.components.turbine.four_quadrant.rated_bases`)
    through the characteristics' own transform (:func:`hillchart.four_quadrant.suter.suter_transform`), y the
    relative opening. A head below zero (a column's separation, not this machine's) is drawn at zero head."""
    from hillchart.four_quadrant.suter import SuterConstants, suter_transform
    from simulate.components.turbine.four_quadrant import rated_bases

    cs = chars.curves[0]
    constants = SuterConstants(k1=float(cs[5]), k2=float(cs[6]), c_h=float(cs[7]), c_y=float(cs[8]))
    h_r, q_r, n_r, m_r = rated_bases(chars, plant.turbine)
    out = []
    for name, result in runs:
        y = result.opening * plant.turbine.opening_max / chars.opening_max
        x, wh, wm = suter_transform(result.speed_rpm / n_r, result.flow_m3_s / q_r,
                                    np.maximum(result.head_m / h_r, 0.0), result.torque_nm / m_r, y,
                                    constants=constants)
        out.append((name, x, wh, wm, y))
    return out


def plot_suter_curves_with_runs(chars, plant, runs, path: Path) -> None:
    """WH(x) and WM(x) of ``chars`` at the openings the runs started and ended at (at most
    :data:`MAX_OPENING_LINES`), each run's path over them (it lies on the curve of its opening: the boundary solved
    it there) with its start marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = suter_paths(chars, plant, runs)
    openings = sorted({round(float(v), 6) for _, _, _, _, y in paths for v in (y[0], y[-1]) if v > 0})
    openings = openings[:: max(1, math.ceil(len(openings) / MAX_OPENING_LINES))]
    x = 2.0 * math.pi * np.arange(CURVE_ANGLES) / CURVE_ANGLES
    fig, axes = plt.subplots(1, 2, figsize=(13, 5))
    for y in openings:
        wh, wm = chars.curve_values(x, np.full(x.size, y))
        for ax, values in zip(axes, (wh, wm)):
            ax.plot(x, values, color="0.55", lw=1.0, label=f"y = {y:.3g}")
    for name, px, wh, wm, _ in paths:
        for ax, values in zip(axes, (wh, wm)):
            line, = ax.plot(px, values, ".", ms=2.5, label=name)
            ax.plot(px[0], values[0], "o", color=line.get_color())
    for ax, label in zip(axes, ("WH", "WM")):
        for edge in (0.5 * math.pi, math.pi, 1.5 * math.pi):
            ax.axvline(edge, color="0.85", lw=0.6)
        ax.set(xlabel="x (rad), turbine convention", ylabel=label, xlim=(0.0, 2.0 * math.pi),
               title=f"{label}(x, y) with each load case's path")
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
