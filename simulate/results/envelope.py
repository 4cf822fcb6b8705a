"""Head envelope along the penstock: max and min piezometric head at every computing node,
and, with a penstock profile (``[[penstock.segments]] elevation_start_m/elevation_end_m``, m above the tailwater
datum of the heads), the pressure head H - z, its minimum and where, and whether the water column separated: with the
discrete vapour or gas cavity model (``penstock.column_separation = "dvcm"`` or ``"dgcm"``, the method of
characteristics) the penstock reports its cavities itself (:mod:`simulate.components.hydraulic.cavitation`); otherwise
a warning says the minimum fell below the vapour pressure, which the model does not represent.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from simulate.results.figures import save_png

#: Vapour pressure of water at 20 degC as a gauge head at sea level: (2.34 kPa - 101.325 kPa) / (rho g), m (the
#: plant's own value comes from its water temperature and atmospheric pressure, :func:`vapour_gauge_head_m`).
VAPOUR_PRESSURE_HEAD_M = (2.34e3 - 101.325e3) / (1000.0 * 9.81)


def node_elevations_m(penstock, x_m: np.ndarray) -> np.ndarray | None:
    """Elevation of the pipe axis at ``x_m`` (distance from the inlet) from the segments' profile, or None
    (the penstock config's ``axis_elevations_m``)."""
    return penstock.axis_elevations_m(x_m)


def vapour_gauge_head_m(penstock) -> float:
    """The vapour pressure as a gauge head at the plant's water temperature and atmospheric pressure
    (``penstock.water_temperature_c``, ``penstock.atmospheric_pressure_head_m``; 20 degC and 10.33 m by default), m."""
    return penstock.vapour_gauge_head_m


def separation_modelled(result) -> bool:
    """Whether the run's penstock modelled the separation (the method of characteristics with the DVCM or the DGCM:
    its run says so in the meta)."""
    return result.meta.get("column_separation_model") in ("dvcm", "dgcm")


def envelope_table(result) -> dict[str, np.ndarray]:
    """Columns of envelope.csv: ``x_m, head_max_m, head_min_m`` and with a profile ``elevation_m,
    pressure_head_max_m, pressure_head_min_m``."""
    table = {"x_m": result.envelope_x_m, "head_max_m": result.envelope_max_m, "head_min_m": result.envelope_min_m}
    z = node_elevations_m(result.plant.penstock, result.envelope_x_m) if result.plant is not None else None
    if z is not None:
        table["elevation_m"] = z
        table["pressure_head_max_m"] = result.envelope_max_m - z
        table["pressure_head_min_m"] = result.envelope_min_m - z
    return table


def envelope_summary(result) -> dict:
    """``summary.json`` entries: min/max piezometric head along the penstock and where; with a profile, the minimum
    pressure head and where, and ``column_separation`` (True when below the vapour pressure)."""
    table = envelope_table(result)
    i_min, i_max = int(np.argmin(table["head_min_m"])), int(np.argmax(table["head_max_m"]))
    out = {"envelope_min_head_m": float(table["head_min_m"][i_min]),
           "envelope_min_head_x_m": float(table["x_m"][i_min]),
           "envelope_max_head_m": float(table["head_max_m"][i_max]),
           "envelope_max_head_x_m": float(table["x_m"][i_max])}
    if "pressure_head_min_m" in table:
        j = int(np.argmin(table["pressure_head_min_m"]))
        out["min_pressure_head_m"] = float(table["pressure_head_min_m"][j])
        out["min_pressure_head_x_m"] = float(table["x_m"][j])
        if separation_modelled(result):  # the heads stop at the vapour head: the cavities say it
            out["column_separation"] = bool(result.meta.get("cavity_nodes", 0) > 0)
        else:
            vapour = vapour_gauge_head_m(result.plant.penstock)
            out["column_separation"] = bool(table["pressure_head_min_m"][j] < vapour)
            if out["column_separation"]:
                out["vapour_gauge_head_m"] = vapour
    return out


def envelope_warnings(summary: dict) -> list[str]:
    """The warning of a minimum below the vapour pressure where the model did not represent the separation
    (``vapour_gauge_head_m`` in the summary); the discrete vapour cavity model warns of its cavities itself."""
    if summary.get("column_separation") and "vapour_gauge_head_m" in summary:
        return [f"the minimum pressure head {summary['min_pressure_head_m']:.3g} m at x = "
                f"{summary['min_pressure_head_x_m']:.4g} m is below the vapour pressure "
                f"({summary['vapour_gauge_head_m']:.3g} m gauge): the water column would separate there, which the "
                f"model does not represent (penstock.column_separation = \"dgcm\" or \"dvcm\" with penstock.model = "
                f"\"moc\" does)"]
    return []


def write_envelope_csv(result, path) -> Path:
    path = Path(path)
    table = envelope_table(result)
    names = list(table)
    np.savetxt(path, np.column_stack([table[c] for c in names]), delimiter=",", header=",".join(names), comments="",
               fmt="%.10g")
    return path


def plot_envelope(result, path=None):
    """Max/min piezometric head along the penstock (and the profile with the vapour-pressure line when given)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    table = envelope_table(result)
    fig = Figure(figsize=(8, 4.5))
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    ax.plot(table["x_m"], table["head_max_m"], "-o", ms=3, label="max head")
    ax.plot(table["x_m"], table["head_min_m"], "-o", ms=3, label="min head")
    if "elevation_m" in table:
        ax.plot(table["x_m"], table["elevation_m"], "k-", lw=1.5, label="pipe axis")
        ax.plot(table["x_m"], table["elevation_m"] + vapour_gauge_head_m(result.plant.penstock), "r--", lw=1,
                label="vapour pressure")
    ax.set_xlabel("distance from the penstock inlet (m)")
    ax.set_ylabel("piezometric head above tailwater (m)")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    ax.set_title(f"head envelope ({result.meta.get('penstock_model', '')})")
    fig.subplots_adjust(left=0.09, right=0.98, bottom=0.115, top=0.925)  # fixed: tight_layout draws once more
    if path is not None:
        save_png(fig, path)
    return fig
