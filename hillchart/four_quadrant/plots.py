"""The four-quadrant figure of the synthetic pump-turbine: its opening lines at unit head (the S-shaped zone), and
its improved Suter curves with the shipped nets. ``python -m hillchart.four_quadrant.plots FOLDER OUT`` writes
``OUT/pump_turbine.png`` from the table folder's nets (``python -m hillchart.four_quadrant.plots
data_synthetic/pump_turbine OUT``)."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

OPENINGS_MM = (4.0, 8.0, 12.0, 16.0, 20.0, 24.0, 28.0)


#: The window of the (N11, Q11) plane the opening lines are drawn in: |N11| r/min, |Q11| m^3/s.
WINDOW_N11_RPM, WINDOW_Q11_M3_S = 160.0, 0.6


def opening_line(turbine, opening_mm: float, points: int = 4001) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(N11, Q11, M11)`` of a machine's opening line over all quadrants (``turbine.unit_curve`` around the
    plane), NaN outside the drawn window (:data:`WINDOW_N11_RPM`, :data:`WINDOW_Q11_M3_S`)."""
    n11, q11, m11 = turbine.unit_curve(opening_mm, np.linspace(-math.pi, math.pi, points))
    window = np.isfinite(n11) & (np.abs(n11) <= WINDOW_N11_RPM) & (np.abs(q11) <= WINDOW_Q11_M3_S)
    return tuple(np.where(window, v, np.nan) for v in (n11, q11, m11))


def plot_four_quadrant(folder, out_dir) -> Path:
    """Draw the figure (module docstring) of the table folder ``folder`` (table.toml, table.csv, nets.json of the
    synthetic pump-turbine) into ``out_dir/pump_turbine.png``. Left: N11-Q11 of each opening line over the four
    quadrants, the runaway points (M11 = 0) marked. Middle and right: WH(x) and WM(x) of the improved transform, exact
    (lines) and nets (dashed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from hillchart.four_quadrant.nets import PUMP_TURBINE_CONSTANTS, load_suter_nets
    from hillchart.four_quadrant.suter import suter_transform
    from hillchart.four_quadrant.table import load_complete_characteristics
    from hillchart.synthetic.pump_turbine import SyntheticPumpTurbine

    turbine = SyntheticPumpTurbine()
    rated = load_complete_characteristics(folder).rated
    nets = load_suter_nets(Path(folder) / "nets.json")
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.8))
    colors = plt.cm.viridis(np.linspace(0, 0.9, len(OPENINGS_MM)))
    for a, color in zip(OPENINGS_MM, colors):
        n11, q11, m11 = opening_line(turbine, a)
        axes[0].plot(n11, q11, color=color, label=f"{a:g} mm")
        cross = np.flatnonzero((n11[:-1] > 0) & (q11[:-1] > 0) & (np.sign(m11[:-1]) != np.sign(m11[1:])))
        axes[0].plot(n11[cross], q11[cross], "o", color=color, ms=4)
        ok = np.isfinite(n11)
        y = a / turbine.opening_max
        x, wh, wm = suter_transform(n11[ok] / rated["n11_rpm"], q11[ok] / rated["q11_m3_s"], 1.0,
                                    m11[ok] / rated["m11_nm"], y, constants=PUMP_TURBINE_CONSTANTS)
        order = np.argsort(x)
        x, wh, wm = x[order], wh[order], wm[order]
        gaps = np.flatnonzero(np.diff(x) > 0.2)  # do not join the ends of a line across the x-range it lacks
        for k, values in ((1, wh), (2, wm)):
            axes[k].plot(np.insert(x, gaps + 1, np.nan), np.insert(values, gaps + 1, np.nan), color=color)
            grid = np.linspace(x.min(), x.max(), 400)
            net = nets.curves(grid, y)[k - 1]
            inside = np.ones_like(grid, bool)
            for g in gaps:
                inside &= ~((grid > x[g]) & (grid < x[g + 1]))
            axes[k].plot(grid, np.where(inside, net, np.nan), "--", color="k", lw=0.8)
    axes[0].axhline(0, color="0.6", lw=0.6)
    axes[0].axvline(0, color="0.6", lw=0.6)
    axes[0].set(xlabel="N11 (r/min)", ylabel="Q11 (m$^3$/s)",
                title="Opening lines at unit head (dots: runaway, M11 = 0)")
    for text, xy in (("turbine", (70, 0.22)), ("reverse pump", (100, -0.25)), ("pump", (-120, -0.35)),
                     ("pump brake", (-120, 0.15))):
        axes[0].annotate(text, xy, color="0.3")
    axes[0].legend(fontsize=7, loc="lower right")
    for k, name in ((1, "WH"), (2, "WM")):
        axes[k].set(xlabel="x (rad), turbine convention", ylabel=name,
                    title=f"Improved Suter curve {name}(x, y): exact, nets dashed")
        for edge in (0.5 * math.pi, math.pi, 1.5 * math.pi):
            axes[k].axvline(edge, color="0.8", lw=0.6)
    fig.tight_layout()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "pump_turbine.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


if __name__ == "__main__":  # python -m hillchart.four_quadrant.plots FOLDER OUT
    if len(sys.argv) != 3:
        raise SystemExit("usage: python -m hillchart.four_quadrant.plots FOLDER OUT")
    print(plot_four_quadrant(sys.argv[1], sys.argv[2]))
