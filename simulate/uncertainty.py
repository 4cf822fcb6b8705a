"""The scenario once per ensemble member: the band of the regulating-guarantee figures (issue 9 section 4).

Only the public seams are used: :func:`simulate.config.load_plant` and
:func:`simulate.engine.run_simulation(plant, characteristics)`; each member of the nets' ensemble (see
:meth:`hillchart.nets.HillNets.members`) is passed as the characteristics. Cost: one simulation per member.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hillchart.errors import HillsimError, InputError

#: Summary figures whose band is reported (fractions of the initial values, see SimulationResult.summary).
BAND_FIGURES = ("max_speed_rise", "max_head_rise", "min_head_drop", "max_head_m")


def _nets_of(plant):
    from hillchart.nets import load_nets

    source = plant.turbine.characteristics
    if source == "ideal":
        raise InputError("--uncertainty needs nets with an ensemble: turbine.characteristics is \"ideal\"")
    path = Path(source)
    if not path.is_absolute():
        path = Path(plant.base_dir) / path
    return load_nets(path)


def run_members(plant, nets=None, *, percentiles=(5.0, 95.0)) -> dict:
    """Simulate ``plant``'s scenario with every ensemble member and return the band of the summary figures.

    Parameters
    ----------
    plant : PlantConfig
        From :func:`simulate.config.load_plant`.
    nets : HillNets, optional
        Default: the plant's ``turbine.characteristics`` nets.json (it must hold an ensemble).
    percentiles : (low, high), percent

    Returns
    -------
    dict
        ``members`` (count), ``failed`` (list of ``{"member", "message"}``), ``percentiles`` and, per figure of
        :data:`BAND_FIGURES`, ``{"low", "high", "mean", "values"}`` over the members that ran.

    Raises
    ------
    InputError
        No ensemble, bad percentiles.
    NumericalError
        Every member failed (the first failure is raised).
    """
    from simulate.engine import run_simulation

    low_p, high_p = (float(p) for p in percentiles)
    if not 0 <= low_p < high_p <= 100:
        raise InputError(f"percentiles must satisfy 0 <= low < high <= 100, got {percentiles!r}")
    nets = _nets_of(plant) if nets is None else nets
    members = nets.members() if hasattr(nets, "members") else []
    if not members:
        raise InputError("--uncertainty needs nets with an ensemble (hillsim train --ensemble N); this nets.json "
                         "has none")
    values = {name: [] for name in BAND_FIGURES}
    failed = []
    first_error = None
    for i, member in enumerate(members):
        try:
            result = run_simulation(plant, characteristics=member, raise_on_failure=True)
        except HillsimError as exc:  # reported per member, never swallowed: all failing is raised below
            failed.append({"member": i, "message": str(exc)})
            first_error = first_error or exc
            continue
        summary = result.summary()
        for name in BAND_FIGURES:
            values[name].append(float(summary[name]))
    if len(failed) == len(members):
        raise first_error
    out = {"members": len(members), "failed": failed, "percentiles": [low_p, high_p]}
    for name, series in values.items():
        arr = np.asarray(series)
        out[name] = {"low": float(np.percentile(arr, low_p)), "high": float(np.percentile(arr, high_p)),
                     "mean": float(arr.mean()), "values": series}
    return out
