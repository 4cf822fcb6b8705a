"""The scenario once per ensemble member: the band of the regulating-guarantee figures.

Only the public seams are used: :func:`simulate.config.load_plant` and
:func:`simulate.loop.engine.run_simulation(plant, characteristics)`; each member of the nets' ensemble (see
:meth:`hillchart.nets.hill_nets.HillNets.members`, and for the Suter nets of a pump-turbine
:meth:`simulate.components.turbine.four_quadrant.SuterCharacteristics.members`) is passed as the characteristics.
Cost: one simulation per member, the members on the machine's cores at once (:func:`simulate.loop.parallel.run_all`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hillchart.errors import HillsimError, InputError
from simulate.studies.case_results import worst_over_units

#: Summary figures whose band is reported (fractions of the initial values, see SimulationResult.summary).
BAND_FIGURES = ("max_speed_rise", "max_head_rise", "min_head_drop", "max_head_m")
#: Figures a run computes only with the head envelope (e.g. not on a rigid penstock), or only for characteristics
#: that can reverse (:mod:`simulate.results.reversal`; a time only where the flow reversed or the unit ran away):
#: banded when every member that ran has it.
OPTIONAL_BAND_FIGURES = ("min_pressure_head_m", "min_draft_tube_pressure_head_m", "max_reverse_speed_pct",
                         "max_reverse_flow_m3_s", "t_flow_reversal_s", "t_runaway_s")
#: Time series whose band over the members is drawn on ``transient.png`` (SimulationResult attributes).
BAND_TRACES = ("speed_rpm", "head_m", "flow_m3_s", "opening")
#: The members' spread is widened by this factor about their median (see :func:`figure_band`).
BAND_INFLATION = 1.1


def figure_band(values, percentiles=(5.0, 95.0), *, inflation: float = BAND_INFLATION, axis=None):
    """``(low, high)`` band of the members' values: their percentiles, widened about the median by ``inflation``.

    The members differ by their data splits, initialisations and readings of the chart, and below the lowest
    digitized opening by their draw of the physical model (what the chart leaves open,
    :meth:`hillchart.extension.turbine_model.FittedTurbineModel.draw`). The factor is the smallest (steps of 0.1)
    whose band covers >= 90 % of the exact figures of the synthetic family's seeds 0 and 1; the held-out seed 2
    is covered as well (``benchmarks/bench_guarantee.py --calibrate``, docs/guarantee-benchmark.md).
    ``low = m - inflation (m - p_low)``, ``high = m + inflation (p_high - m)`` with
    ``m`` the median; ``inflation`` 1 gives the plain percentiles.

    Examples
    --------
    >>> [round(float(v), 6) for v in figure_band([1.0, 2.0, 3.0], (0.0, 100.0), inflation=2.0)]
    [0.0, 4.0]
    """
    arr = np.asarray(values, dtype=float)
    low, mid, high = np.percentile(arr, [percentiles[0], 50.0, percentiles[1]], axis=axis)
    return mid - inflation * (mid - low), mid + inflation * (high - mid)


@dataclass(frozen=True)
class TraceBand:
    """Percentile band of time series over the ensemble members, on the runs' common time grid.

    Attributes
    ----------
    time_s : ndarray (T,)
    low, high : dict
        ``{name: ndarray (T,)}`` for the names of :data:`BAND_TRACES` (units of the SimulationResult attributes).
    percentiles : (float, float)
    members : int
        Members that ran (failed ones are not in the band).
    figures : dict
        ``{figure: (low, high)}``: the band of each guarantee figure of :data:`BAND_FIGURES` (fractions of the
        initial value, as in the summary), drawn at the figure on ``transient.png``.
    """

    time_s: np.ndarray
    low: dict
    high: dict
    percentiles: tuple
    members: int
    figures: dict = field(default_factory=dict)


def _nets_of(plant):
    """The plant's nets, its turbine's own characteristics (:func:`simulate.components.turbine.component.
    characteristics_of`): with ``[turbine.step_up]`` every member is stepped up like the point nets."""
    from simulate.components.turbine.component import characteristics_of
    from simulate.components.turbine.kinds import nets_path

    spec = plant.turbine.characteristics
    if nets_path(spec, plant.base_dir) is None:
        raise InputError(f"--uncertainty needs nets with an ensemble: turbine.characteristics is {spec!r}, not a "
                         f"nets.json")
    return characteristics_of(plant)


def run_members(plant, nets=None, *, percentiles=(5.0, 95.0)) -> dict:
    """Simulate ``plant``'s scenario with every ensemble member and return the band of the summary figures
    (the first item of :func:`run_ensemble`)."""
    return run_ensemble(plant, nets, percentiles=percentiles)[0]


def uncalibrated_band_note(characteristics) -> str | None:
    """What to say of an ensemble band that is the members' training spread alone: four-quadrant nets whose band
    was not calibrated on their table's lines (``training.band``, :func:`hillchart.four_quadrant.nets.band_factor`;
    nets.json written before the calibration has no record). On a real pump-turbine's table such a band covered
    half the curve values between its lines. None for every other characteristics (the hill chart's band is
    calibrated on the chart's own held-out lines)."""
    from hillchart.four_quadrant.nets import SuterNets

    suter = getattr(characteristics, "nets", None)
    if not isinstance(suter, SuterNets) or not suter.members:
        return None
    band = (getattr(suter, "training", None) or {}).get("band") or {}
    if band.get("calibrated"):
        return None
    why = f" ({band['why']})" if band.get("why") else ""
    return ("the band of these four-quadrant nets is their members' training spread, not calibrated on the table's "
            f"lines{why}, and understates the nets' error between measured lines; retrain them with hillsim "
            "four-quadrant TABLE_DIR --out nets.json")


def run_ensemble(plant, nets=None, *, percentiles=(5.0, 95.0), workers: int | None = None) -> tuple[dict, TraceBand]:
    """Simulate ``plant``'s scenario with every ensemble member: the band of the summary figures and of the traces.

    Parameters
    ----------
    plant : PlantConfig
        From :func:`simulate.config.load_plant`.
    nets : HillNets or SuterCharacteristics of nets, optional
        Default: the plant's ``turbine.characteristics`` nets.json (it must hold an ensemble: ``members()``).
    percentiles : (low, high), percent
    workers : int, optional
        Threads running the members (default: the cores this process may use; see
        :func:`simulate.loop.parallel.run_all`).

    Returns
    -------
    band : dict
        ``members`` (count), ``failed`` (list of ``{"member", "message"}``), ``percentiles`` and, per figure of
        :data:`BAND_FIGURES`, ``{"low", "high", "mean", "values"}`` over the members that ran (JSON-ready).
    traces : TraceBand
        The same percentiles of the :data:`BAND_TRACES` series at every time step (drawn on ``transient.png``).

    Raises
    ------
    InputError
        No ensemble, bad percentiles.
    NumericalError
        Every member failed (the first failure is raised).
    """
    from simulate.loop.parallel import run_all

    low_p, high_p = (float(p) for p in percentiles)
    if not 0 <= low_p < high_p <= 100:
        raise InputError(f"percentiles must satisfy 0 <= low < high <= 100, got {percentiles!r}")
    nets = _nets_of(plant) if nets is None else nets
    members = nets.members() if hasattr(nets, "members") else []
    if not members:
        raise InputError("--uncertainty needs nets with an ensemble (hillsim train --ensemble N); this nets.json "
                         "has none")
    values = {name: [] for name in BAND_FIGURES + OPTIONAL_BAND_FIGURES}
    traces = {name: [] for name in BAND_TRACES}
    time_s = None
    failed = []
    first_error = None
    # the members at once on the machine's cores (each result is that of a single run)
    for i, result in enumerate(run_all([(plant, member) for member in members], workers=workers)):
        if isinstance(result, HillsimError):  # reported per member, never swallowed: all failing is raised below
            failed.append({"member": i, "message": str(result)})
            first_error = first_error or result
            continue
        summary = result.summary()
        for name in BAND_FIGURES:
            values[name].append(float(summary[name]))
        for name in OPTIONAL_BAND_FIGURES:  # with several units, the worst unit's
            value = worst_over_units(summary, name)
            if value is not None:
                values[name].append(float(value))
        time_s = result.time_s  # the same plant: the same time grid for every member that ran to the end
        for name in BAND_TRACES:
            traces[name].append(np.asarray(getattr(result, name), dtype=float))
    if len(failed) == len(members):
        raise first_error
    out = {"members": len(members), "failed": failed, "percentiles": [low_p, high_p]}
    if (note := uncalibrated_band_note(nets)) is not None:
        out["warnings"] = [note]
    ran = len(members) - len(failed)
    for name, series in values.items():
        if name in OPTIONAL_BAND_FIGURES and len(series) != ran:
            continue
        low, high = figure_band(series, (low_p, high_p))
        out[name] = {"low": float(low), "high": float(high), "mean": float(np.mean(series)), "values": series}
    stacked = {name: np.vstack(rows) for name, rows in traces.items()}
    bands = {k: figure_band(v, (low_p, high_p), axis=0) for k, v in stacked.items()}
    band = TraceBand(time_s=np.asarray(time_s), low={k: v[0] for k, v in bands.items()},
                     high={k: v[1] for k, v in bands.items()},
                     percentiles=(low_p, high_p), members=len(members) - len(failed),
                     figures={name: (out[name]["low"], out[name]["high"]) for name in BAND_FIGURES if name in out})
    return out, band
