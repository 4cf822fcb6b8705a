"""The pair of nets of a turbine (:class:`HillNets`: Q11 and M11, with the ensemble of the band and the digitized
region) and its nets.json file."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from hillchart.errors import InputError
from hillchart.nets.estimator import _check_percentiles
from hillchart.nets.silent_model import (SilentRegionModel, _silent_nets_flow, _silent_nets_kernel,
                                         _silent_nets_torque)
from hillchart.nets.weights import (FIXED_UNITS, FORMAT, VERSION, NetWeights, _nets_flow, _nets_kernel, _nets_torque,
                                    ensemble_blocks)


# ----------------------------------------------------------------------------------------------------------------
# the pair: Characteristics for the simulator, nets.json
# ----------------------------------------------------------------------------------------------------------------
class HillNets:
    """Flow net Q11(N11, a) (m^3/s) and torque net M11(N11, a) (N*m): eq. (12) of paper 004.

    Implements :class:`hillchart.characteristics.Characteristics` (vectorized numpy in and out, compiled
    evaluation, no torch) and ``numba_kernel()`` for the simulator's compiled loop.

    Parameters
    ----------
    flow, torque : NetWeights
    opening_unit : str
        The chart's opening unit ("mm", "deg", "%").
    training : dict, optional
        Training record written to ``nets.json`` (JSON-serializable).

    Examples
    --------
    >>> w = NetWeights(x_min=[0.0, 0.0], x_max=[100.0, 30.0], y_min=0.0, y_max=1.0,
    ...                W1=[[0.0, 1.0]], b1=[0.0], W2=[2.0], b2=-1.0)
    >>> nets = HillNets(flow=w, torque=w, opening_unit="mm")
    >>> float(nets.q11(40.0, 15.0))
    0.5
    >>> nets2 = HillNets.from_json(nets.to_json())
    >>> nets2.flow == nets.flow
    True
    """

    def __init__(self, flow: NetWeights, torque: NetWeights, opening_unit: str, training: dict | None = None,
                 ensemble=None, digitized_region=None, silent_model=None, member_silent_models=None):
        if not isinstance(flow, NetWeights) or not isinstance(torque, NetWeights):
            raise InputError("HillNets.flow and HillNets.torque must be NetWeights")
        if not isinstance(opening_unit, str) or not opening_unit:
            raise InputError(f"HillNets.opening_unit must be a non-empty string, got {opening_unit!r}")
        self.flow = flow
        self.torque = torque
        self.opening_unit = opening_unit
        self.training = dict(training or {})
        pairs = list(ensemble or [])
        for i, pair in enumerate(pairs):
            if not (isinstance(pair, (tuple, list)) and len(pair) == 2
                    and all(isinstance(w, NetWeights) for w in pair)):
                raise InputError(f"HillNets.ensemble[{i}] must be a (flow, torque) pair of NetWeights")
        self.ensemble = [tuple(p) for p in pairs]
        #: Vertices (k, 2) of the convex hull of the digitized (N11 r/min, opening) points the nets were trained
        #: on, or None (files written before it was recorded): what a run needs to say when it leaves the chart,
        #: wherever the nets.json is kept.
        self.digitized_region = None if digitized_region is None else _region(digitized_region, "digitized_region")
        #: The fitted physical model that answers below the lowest digitized opening
        #: (:class:`hillchart.nets.silent_model.SilentRegionModel`), or None: the nets alone everywhere.
        if silent_model is not None and not isinstance(silent_model, SilentRegionModel):
            raise InputError("HillNets.silent_model must be a SilentRegionModel or None")
        self.silent_model = silent_model
        #: One silent-region model per ensemble member (drawn from what the chart leaves open), or None: the
        #: members share :attr:`silent_model`.
        drawn = None if member_silent_models is None else list(member_silent_models)
        if drawn is not None and (len(drawn) != len(self.ensemble) or silent_model is None
                                  or not all(isinstance(m, SilentRegionModel) for m in drawn)):
            raise InputError("HillNets.member_silent_models must hold one SilentRegionModel per ensemble member, "
                             "beside a silent_model")
        self.member_silent_models = drawn

    # ensemble: uncertainty band ------------------------------------------------------------------------------------
    def members(self) -> list["HillNets"]:
        """The ensemble members as HillNets (empty when the file has no ensemble)."""
        silent = self.member_silent_models or [self.silent_model] * len(self.ensemble)
        return [HillNets(flow=f, torque=t, opening_unit=self.opening_unit, digitized_region=self.digitized_region,
                         silent_model=s)
                for (f, t), s in zip(self.ensemble, silent)]

    def band(self, quantity: str, n11, opening, *, percentiles=(5.0, 95.0)) -> dict:
        """Mean and percentile band of ``quantity`` over the ensemble members.

        Parameters
        ----------
        quantity : {"q11", "m11", "efficiency"}
        n11, opening : array_like (broadcast), r/min and chart units
        percentiles : (low, high), percent

        Returns
        -------
        dict
            ``mean``, ``low``, ``high`` (arrays of the broadcast shape; Q11 m^3/s, M11 N*m, efficiency fraction)
            and ``point`` (the point-estimate nets).

        Raises
        ------
        InputError
            Unknown quantity, bad percentiles, or no ensemble in these nets.
        """
        if quantity not in ("q11", "m11", "efficiency"):
            raise InputError(f"quantity must be 'q11', 'm11' or 'efficiency', got {quantity!r}")
        low_p, high_p = _check_percentiles(percentiles)
        if not self.ensemble:
            raise InputError("these nets have no ensemble (train with --ensemble N)")
        values = np.array([getattr(m, quantity)(n11, opening) for m in self.members()])
        # np.nanpercentile along an axis loops over the points in Python (2.3 s for the 81 x 81 trust map);
        # np.percentile gives the same numbers when nothing is NaN (efficiency can be NaN where Q11 <= 0)
        percentile = np.percentile if np.all(np.isfinite(values)) else np.nanpercentile
        return {"mean": np.nanmean(values, axis=0), "low": percentile(values, low_p, axis=0),
                "high": percentile(values, high_p, axis=0), "point": getattr(self, quantity)(n11, opening)}

    # Characteristics protocol -----------------------------------------------------------------------------------
    def _evaluate(self, which: int, n11, opening):
        """(value, d/dN11, d/da) of the flow (0) or torque (1) characteristic: the net, or the net blended into
        the silent-region model below the lowest digitized opening."""
        if self.silent_model is None:
            return (self.flow if which == 0 else self.torque).evaluate(n11, opening)
        values = self.silent_model.evaluate(self.flow, self.torque, n11, opening)
        return values[3 * which:3 * which + 3]

    def q11(self, n11, opening) -> np.ndarray:
        """Unit flow Q11, m^3/s, at N11 (r/min) and opening (chart units), broadcast."""
        return self._evaluate(0, n11, opening)[0]

    def m11(self, n11, opening) -> np.ndarray:
        """Unit torque M11, N*m."""
        return self._evaluate(1, n11, opening)[0]

    def q11_grad(self, n11, opening) -> tuple[np.ndarray, np.ndarray]:
        """(dQ11/dN11 in m^3/s per r/min, dQ11/da in m^3/s per opening unit)."""
        return self._evaluate(0, n11, opening)[1:]

    def m11_grad(self, n11, opening) -> tuple[np.ndarray, np.ndarray]:
        """(dM11/dN11 in N*m per r/min, dM11/da in N*m per opening unit)."""
        return self._evaluate(1, n11, opening)[1:]

    def efficiency(self, n11, opening) -> np.ndarray:
        """Hydraulic efficiency eta = M11 omega11 / (rho g Q11) (inverse of eq. (5), paper 004); NaN where
        Q11 <= 0 or N11 <= 0."""
        from hillchart.characteristics import efficiency_from_unit_torque

        n11 = np.asarray(n11, dtype=float)
        return efficiency_from_unit_torque(self.q11(n11, opening), n11, self.m11(n11, opening))

    def numba_kernel(self):
        """``(kernel, params)``: ``kernel(params, n11, a) -> (q11, dq11_dn11, dq11_da, m11, dm11_dn11, dm11_da)``,
        numba-jitted, on scalars (see :mod:`hillchart.characteristics`)."""
        if self.silent_model is not None:
            return _silent_nets_kernel, (self.flow.packed(), self.torque.packed(), self.silent_model.packed())
        return _nets_kernel, (self.flow.packed(), self.torque.packed())

    def numba_value_kernels(self):
        """``(flow, torque)``: numba functions ``(params, n11, a) -> q11`` and ``-> m11`` on the params of
        :meth:`numba_kernel`, the values of its kernel without the derivatives (what the pressure loop's iterations
        and the torque at the converged head read)."""
        if self.silent_model is not None:
            return _silent_nets_flow, _silent_nets_torque
        return _nets_flow, _nets_torque

    # nets.json --------------------------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        doc = {"format": FORMAT, "version": VERSION,
               "units": {"n11": FIXED_UNITS["n11"], "opening": self.opening_unit, "q11": FIXED_UNITS["q11"],
                         "m11": FIXED_UNITS["m11"]},
               "flow": self.flow.to_dict("q11"), "torque": self.torque.to_dict("m11"),
               "training": self.training}
        if self.ensemble:
            doc["ensemble"] = [{"flow": f.to_dict("q11"), "torque": t.to_dict("m11")} for f, t in self.ensemble]
            for member, silent in zip(doc["ensemble"], self.member_silent_models or []):
                # a member on the top-level table is its place in the band; anything else is written whole
                same = (self.silent_model is not None and silent.at(0.0).packed().tobytes()
                        == self.silent_model.at(0.0).packed().tobytes())
                member["silent_model"] = silent.member_dict() if same else silent.to_dict()
        if self.digitized_region is not None:
            doc["digitized_region"] = self.digitized_region.tolist()
        if self.silent_model is not None:
            doc["silent_model"] = self.silent_model.to_dict()
        return doc

    def to_json(self) -> str:
        """``nets.json`` text (floats in shortest round-trip form, so loading is bit-exact)."""
        return nets_json_text(self.to_dict())

    def save(self, path) -> Path:
        """Write ``nets.json`` to ``path``; returns the path."""
        path = Path(path)
        path.write_text(self.to_json(), encoding="utf-8")
        return path

    @classmethod
    def from_dict(cls, doc) -> "HillNets":
        """Validate a parsed ``nets.json`` document (see module docstring)."""
        if not isinstance(doc, dict):
            raise InputError(f"nets.json must hold an object, got {type(doc).__name__}")
        for key in ("format", "version", "units", "flow", "torque"):
            if key not in doc:
                raise InputError(f"nets.json: key {key!r} is missing (required: format, version, units, flow, "
                                 f"torque)")
        if doc["format"] != FORMAT:
            raise InputError(f"nets.json: format must be {FORMAT!r}, got {doc['format']!r}")
        if doc["version"] != VERSION or isinstance(doc["version"], bool):
            raise InputError(f"nets.json: version must be {VERSION}, got {doc['version']!r}")
        units = doc["units"]
        if not isinstance(units, dict):
            raise InputError(f"nets.json: units must be an object, got {units!r}")
        for name, unit in FIXED_UNITS.items():
            if units.get(name) != unit:  # format check, not a default: a missing key reads as None here
                raise InputError(f"nets.json: units.{name} must be {unit!r}, got {units.get(name)!r}")
        if "opening" not in units or not isinstance(units["opening"], str) or not units["opening"]:
            raise InputError(f"nets.json: units.opening must be the chart's opening unit (a string), got "
                             f"{units.get('opening')!r}")
        flow = NetWeights.from_dict(doc["flow"], key="flow", output="q11")
        torque = NetWeights.from_dict(doc["torque"], key="torque", output="m11")
        training = doc["training"] if "training" in doc else {}
        if not isinstance(training, dict):
            raise InputError(f"nets.json: training must be an object, got {type(training).__name__}")
        ensemble, member_silent = [], []
        silent = SilentRegionModel.from_dict(doc["silent_model"]) if "silent_model" in doc else None
        # optional; a file without it is the version-1 file of before
        for i, member in enumerate(ensemble_blocks(doc, prefix="nets.json: ",
                                                   silent_hint=" beside a top-level silent_model")):
            ensemble.append((NetWeights.from_dict(member["flow"], key=f"ensemble[{i}].flow", output="q11"),
                             NetWeights.from_dict(member["torque"], key=f"ensemble[{i}].torque", output="m11")))
            if "silent_model" in member:
                key = f"ensemble[{i}].silent_model"
                if silent is None:
                    raise InputError("nets.json: ensemble members carry silent_model blocks, so the file must have "
                                     "a top-level silent_model")
                member_silent.append(silent.member_from_dict(member["silent_model"], key))
        region = _region(doc["digitized_region"], "nets.json: digitized_region") if "digitized_region" in doc else None
        _check_members(flow, torque, ensemble, region)
        if member_silent and (silent is None or len(member_silent) != len(ensemble)):
            raise InputError("nets.json: ensemble members carry silent_model blocks, so every member must, and the "
                             "file must have a top-level silent_model")
        return cls(flow=flow, torque=torque, opening_unit=units["opening"], training=training, ensemble=ensemble,
                   digitized_region=region, silent_model=silent, member_silent_models=member_silent or None)

    @classmethod
    def from_json(cls, text: str) -> "HillNets":
        """Parse ``nets.json`` text; rejects invalid JSON and malformed blocks (NaN/Infinity literals and numbers
        that overflow to inf are rejected by the block validation, which names the key)."""
        return cls.from_dict(parse_nets_json(text))


def parse_nets_json(text: str):
    """The JSON document of ``nets.json`` text (two- or three-input nets), every failure an InputError starting
    ``"nets.json: "``: invalid JSON, nesting deeper than Python's parser recurses (a NET block is 2 levels deep),
    an integer beyond Python's digit limit."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"nets.json: not valid JSON ({exc})") from None
    except RecursionError:
        raise InputError("nets.json: nested too deeply to be a nets file (a NET block is 2 levels deep)") from None
    except ValueError as exc:  # e.g. an integer beyond Python's 4300-digit conversion limit
        raise InputError(f"nets.json: not a valid nets file ({exc})") from None


def read_nets_json(path):
    """The JSON document of the nets file ``path`` (the one reader of every nets.json: two-input nets, three-input
    nets and the check which of the two a file holds); an InputError names the file: a folder, not UTF-8 text (a
    UTF-8 byte-order mark is accepted), or what :func:`parse_nets_json` refuses."""
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{path}: is a folder, not a nets.json file")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not a UTF-8 text file ({exc.reason} at byte {exc.start}); nets.json is JSON "
                         "text") from None
    try:
        return parse_nets_json(text)
    except InputError as exc:
        raise InputError(f"{path}: {str(exc).removeprefix('nets.json: ')}") from None


def nets_json_text(doc: dict) -> str:
    """The text of a ``nets.json`` document (two- or three-input nets): one line per key of a NET block, per
    vertex of the digitized region and per ensemble member, other values indented; floats in shortest round-trip
    form, so loading is bit-exact."""
    lines = []
    for key, value in doc.items():
        if key in ("flow", "torque"):  # one line per NET key, weight lists kept on one line
            inner = ",\n".join(f"  {json.dumps(k)}: {json.dumps(v, allow_nan=False)}" for k, v in value.items())
            lines.append(f" {json.dumps(key)}: {{\n{inner}\n }}")
        elif key == "digitized_region":  # one line per vertex
            vertices = ",\n".join(f"  {json.dumps(v, allow_nan=False)}" for v in value)
            lines.append(f" {json.dumps(key)}: [\n{vertices}\n ]")
        elif key == "ensemble":  # one line per member NET
            members = ",\n".join(
                "  {" + ", ".join(f"{json.dumps(k)}: {json.dumps(v, allow_nan=False)}" for k, v in m.items()) + "}"
                for m in value)
            lines.append(f" {json.dumps(key)}: [\n{members}\n ]")
        else:
            text = json.dumps(value, indent=1, allow_nan=False).replace("\n", "\n ")
            lines.append(f" {json.dumps(key)}: {text}")
    return "{\n" + ",\n".join(lines) + "\n}\n"


def _region(value, key: str) -> np.ndarray:
    """A digitized region: at least 3 finite (N11, opening) vertices."""
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{key} must be a list of [n11, opening] pairs, got {str(value)[:80]}") from None
    if array.ndim != 2 or array.shape[1] != 2 or len(array) < 3:
        raise InputError(f"{key} must be a list of at least 3 [n11, opening] pairs, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise InputError(f"{key} must hold finite numbers")
    return array


def load_nets(path) -> HillNets:
    """Read and validate ``nets.json``.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    HillNets

    Raises
    ------
    InputError
        Wrong format or version, missing keys, wrong shapes, NaN/inf, ``x_max <= x_min``: the message names the key.
    FileNotFoundError
        No such file.

    Examples
    --------
    >>> from importlib.resources import files
    >>> nets = load_nets(files("data_synthetic.francis") / "nets.json")  # the shipped synthetic-Francis nets
    >>> nets.opening_unit, nets.flow.hidden, len(nets.ensemble)  # hidden size chosen by cross-validation
    ('mm', 8, 10)
    >>> abs(float(nets.efficiency(65.0, 18.0)) - 0.935) < 0.005  # best efficiency of the synthetic turbine: 0.935
    True
    """
    path = Path(path)
    doc = read_nets_json(path)
    try:
        return HillNets.from_dict(doc)
    except InputError as exc:
        message = str(exc).removeprefix("nets.json: ")
        raise InputError(f"{path}: {message}") from None


#: Largest median departure of an ensemble member from the point net where the chart has data (its digitized region;
#: the training box for nets that record none), as a fraction of the output range: members trained on other splits of
#: the same samples depart by 0.1-0.5 % in the median on the shipped chart (their largest departures, in the box's
#: corners far from any sample, reach 32 % on a sparse real Kaplan table, so the median, not the largest, is judged);
#: a member 25 % off in the median is not a member of this ensemble (a corrupted or foreign block). Outside the
#: digitized region members may stand apart: that is their band where the chart gives little evidence.
MEMBER_DEPARTURE = 0.25
#: The grid points (of 15 x 15 over the training box) that must fall in the digitized region for it to be judged.
MIN_REGION_POINTS = 9


def _check_members(flow: NetWeights, torque: NetWeights, ensemble, region=None) -> None:
    """Refuse an ensemble member whose median departure from the point nets exceeds :data:`MEMBER_DEPARTURE` of their
    output range, naming the member: over the points of a 15 x 15 grid of the training box inside the digitized
    ``region`` (at least :data:`MIN_REGION_POINTS`), else over a 7 x 7 grid of the whole box (evaluated in Python, so
    loading nets loads no compiled kernel)."""
    if not ensemble:
        return
    where = "the training box"
    n11, opening = np.meshgrid(np.linspace(flow.x_min[0], flow.x_max[0], 7),
                               np.linspace(flow.x_min[1], flow.x_max[1], 7))
    if region is not None:
        from hillchart.io.samples import measured_region_mask

        fine_n11, fine_opening = (v.ravel() for v in np.meshgrid(np.linspace(flow.x_min[0], flow.x_max[0], 15),
                                                                  np.linspace(flow.x_min[1], flow.x_max[1], 15)))
        inside = measured_region_mask(region[:, 0], region[:, 1], fine_n11, fine_opening)
        if inside.sum() >= MIN_REGION_POINTS:
            n11, opening, where = fine_n11[inside], fine_opening[inside], "the digitized region"
    references = {"flow": flow.evaluate(n11, opening)[0], "torque": torque.evaluate(n11, opening)[0]}
    for i, pair in enumerate(ensemble):
        for name, point, member in (("flow", flow, pair[0]), ("torque", torque, pair[1])):
            reference = references[name]
            departure = float(np.median(np.abs(member.evaluate(n11, opening)[0] - reference))
                              / (point.y_max - point.y_min))
            if not departure <= MEMBER_DEPARTURE:
                raise InputError(f"nets.json: ensemble[{i}].{name} departs from the point net by {departure:.0%} of "
                                 f"its output range in the median over {where} (members of one ensemble "
                                 f"depart by well under 1 %, allowed {MEMBER_DEPARTURE:.0%}): a corrupted or foreign "
                                 f"member; train the nets again (hillsim train) or remove the member")
