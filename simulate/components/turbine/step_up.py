"""Model -> prototype: the IEC 60193 efficiency step-up of a hill chart measured on a model (``[turbine.step_up]``).

A digitized hill chart is almost always a model test (a runner of some 0.3-0.5 m at some 30 m of head); the plant
is the prototype. Its Reynolds number is one or two orders of magnitude larger, its scalable (friction) losses
smaller, so its efficiency is higher. IEC 60193:1999 ("Hydraulic turbines, storage pumps and pump-turbines - Model
acceptance tests"), subclause 3.8.2.2, converts the model's hydraulic efficiency to the prototype's for reaction
machines by the Reynolds number Re = D u / nu (u = pi D n / 60 the peripheral speed at the reference diameter)::

    delta_ref = (1 - eta_hoptM) / ((Re_ref / Re_Mopt)^0.16 + (1 - V_ref) / V_ref)         (relative scalable losses)
    Delta_eta = delta_ref ((Re_ref / Re_M)^0.16 - (Re_ref / Re_P)^0.16)                   (efficiency step-up)
    eta_hP = eta_hM + Delta_eta

with Re_ref = 7e6 and V_ref = 0.7 (the share of the losses that scale with Re at Re_ref; IEC 60193's value for
radial machines). The standard keeps the unit discharge (Q11P = Q11M at the same N11 and opening) and raises the
power, hence the unit torque. (IEC 62097:2009/2019 later revised this formula; its split of the step-up between
discharge and torque needs the chart's loss breakdown, which a digitized chart does not give.)

How hillsim applies it. Delta_eta is evaluated once, at the chart's best-efficiency point (N11_opt, eta_hoptM):
the model runs there at n_M = N11_opt sqrt(H_M) / D_M, the prototype at n_P = N11_opt sqrt(H_r) / D1 (the plant's
rated head and runner diameter). The torque characteristic is then multiplied by one constant factor, flow unchanged::

    M11_P(N11, a) = M11_M(N11, a) (eta_hoptM + Delta_eta) / eta_hoptM,     Q11_P(N11, a) = Q11_M(N11, a)

so the efficiency rises by exactly Delta_eta at the best-efficiency point and by Delta_eta eta_M / eta_hoptM
elsewhere (within 0.1 point of Delta_eta where the efficiency is above 0.85 of its best). Why a factor and not
Delta_eta added everywhere: adding Delta_eta at every point adds the torque rho g Q11 Delta_eta / omega11, which
grows without bound toward zero speed (the chart's zero-speed boundary) and moves the runaway curve M11 = 0, where
a chart with a measured runaway curve says the prototype runs away too; a factor keeps both, keeps the nets smooth
and leaves the six transfer coefficients (logarithmic derivatives of M11 and Q11) unchanged, so only the operating
point moves. For trained nets the factor goes into the torque net's output scaling (the same compiled kernel).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hillchart.errors import InputError
from simulate.components.parameters import parameter, read_section, section_dict, validate_parameters

#: Methods of ``turbine.step_up.method``.
STEP_UP_METHODS = ("iec60193",)
#: Exponent of the Reynolds-number ratio in IEC 60193's step-up formula.
REYNOLDS_EXPONENT = 0.16


@dataclass(frozen=True)
class StepUpConfig:
    """``[turbine.step_up]``: the chart is a model test; convert its efficiency to the prototype's (IEC 60193).

    Add the table (``method = "iec60193"`` alone takes every default) when the hill chart comes from a model
    test: the prototype (the plant's ``turbine.runner_diameter_m`` at ``turbine.rated_head_m``) then gets the
    efficiency step-up ``Delta_eta`` of IEC 60193:1999, 3.8.2.2, applied as a constant factor on the unit torque
    (flow unchanged); the equations are in the "Model and prototype" section of the simulator page. The defaults
    are those of a typical model test: a 0.35 m runner at 30 m of head in water at 20 C (kinematic viscosity
    1.0e-6 m^2/s). ``model_efficiency_reference``: the model's best hydraulic efficiency eta_hoptM (default: the
    highest efficiency of the characteristics inside the digitized region, found on a grid).
    ``scalable_loss_share`` is V_ref (0.7 for radial machines in IEC 60193), ``reynolds_reference`` Re_ref.
    """

    method: str = parameter("iec60193", unit="", choices=STEP_UP_METHODS, description="the step-up formula")
    model_diameter_m: float = parameter(0.35, unit="m", low=0.0, low_open=True, high=20.0,
                                        description="the model's runner diameter")
    model_head_m: float = parameter(30.0, unit="m", low=0.0, low_open=True, high=3000.0,
                                    description="the model test's head")
    model_efficiency_reference: float | None = parameter(
        None, unit="1", low=0.3, high=1.0, high_open=True,
        description="the model's best hydraulic efficiency (default: the characteristics' best)")
    # water from about 0 C (1.79e-6) to 100 C (0.29e-6)
    kinematic_viscosity_m2_s: float = parameter(1.0e-6, unit="m^2/s", low=2e-7, high=2e-6,
                                                description="kinematic viscosity of the water")
    scalable_loss_share: float = parameter(0.7, unit="1", low=0.0, low_open=True, high=1.0,
                                           description="V_ref, the share of the losses that scale")
    reynolds_reference: float = parameter(7.0e6, unit="1", low=1e5, high=1e9, description="Re_ref")

    def __post_init__(self):
        validate_parameters("turbine.step_up", self)

    @classmethod
    def from_toml(cls, raw) -> "StepUpConfig":
        """From the ``[turbine.step_up]`` table (strict keys: an unknown key names the valid ones)."""
        if not isinstance(raw, dict):
            raise InputError(f"turbine.step_up must be a table such as {{method = \"iec60193\"}}, got {raw!r}")
        return read_section("turbine.step_up", cls, raw)

    def as_dict(self) -> dict:
        """The TOML table (keys left at None omitted)."""
        return section_dict(self)


def reynolds_number(diameter_m, speed_rpm, kinematic_viscosity_m2_s):
    """Re = D u / nu with u = pi D n / 60 the peripheral speed at the reference diameter (IEC 60193's Re).

    Examples
    --------
    >>> round(reynolds_number(0.35, 1000.0, 1.0e-6))
    6414085
    """
    return np.asarray(diameter_m, float) * math.pi * np.asarray(diameter_m, float) * np.asarray(speed_rpm, float) \
        / 60.0 / kinematic_viscosity_m2_s


def iec60193_step_up(eta_model_best, reynolds_model, reynolds_prototype, *, scalable_loss_share: float = 0.7,
                     reynolds_reference: float = 7.0e6) -> float:
    """Efficiency step-up Delta_eta = eta_hP - eta_hM of IEC 60193:1999, 3.8.2.2, at the best-efficiency point::

        delta_ref = (1 - eta_hoptM) / ((Re_ref / Re_M)^0.16 + (1 - V_ref) / V_ref)
        Delta_eta = delta_ref ((Re_ref / Re_M)^0.16 - (Re_ref / Re_P)^0.16)

    Parameters
    ----------
    eta_model_best : float
        The model's best hydraulic efficiency eta_hoptM, fraction.
    reynolds_model, reynolds_prototype : float
        Re_M and Re_P at the best-efficiency point (:func:`reynolds_number`).
    scalable_loss_share : float
        V_ref (0.7 in IEC 60193 for radial machines).
    reynolds_reference : float
        Re_ref (7e6).

    Returns
    -------
    float
        Delta_eta, fraction (negative when the prototype's Reynolds number is the smaller).

    Examples
    --------
    >>> round(iec60193_step_up(0.92, 7.0e6, 7.0e8), 7)   # 0.08 / (1 + 0.3/0.7) * (1 - 0.01^0.16)
    0.0291967
    """
    ratio_model = (reynolds_reference / reynolds_model) ** REYNOLDS_EXPONENT
    ratio_prototype = (reynolds_reference / reynolds_prototype) ** REYNOLDS_EXPONENT
    delta_ref = (1.0 - eta_model_best) / (ratio_model + (1.0 - scalable_loss_share) / scalable_loss_share)
    return float(delta_ref * (ratio_model - ratio_prototype))


def _search_box(characteristics):
    """``(n11 grid, opening grid, mask)`` where the best efficiency is looked for: the digitized region when the
    characteristics record it, else the nets' input range, else N11 30-110 r/min at openings up to opening_max."""
    region = getattr(characteristics, "digitized_region", None)
    flow = getattr(characteristics, "flow", None)
    if region is not None and len(region) >= 3:
        region = np.asarray(region, float)
        lo, hi = region.min(axis=0), region.max(axis=0)
    elif flow is not None and hasattr(flow, "x_min"):
        lo, hi = np.asarray(flow.x_min, float), np.asarray(flow.x_max, float)
        region = None
    elif getattr(characteristics, "opening_max", None) is not None:
        lo, hi = np.array([30.0, 0.0]), np.array([110.0, float(characteristics.opening_max)])
        region = None
    else:
        raise InputError("turbine.step_up: these characteristics record neither their digitized region nor their "
                         "input range, so their best-efficiency point cannot be found; give "
                         "turbine.step_up.model_efficiency_reference")
    n11, opening = np.meshgrid(np.linspace(max(lo[0], 1.0), hi[0], 161), np.linspace(max(lo[1], 1e-3 * hi[1]),
                                                                                     hi[1], 161))
    mask = np.ones(n11.shape, dtype=bool)
    if region is not None:  # inside the convex polygon, either orientation
        area = np.sum(region[:, 0] * np.roll(region[:, 1], -1) - np.roll(region[:, 0], -1) * region[:, 1])
        sign = 1.0 if area >= 0 else -1.0
        span = (hi - lo) + 1e-300
        for (x0, y0), (x1, y1) in zip(region, np.roll(region, -1, axis=0)):
            cross = (x1 - x0) * (opening - y0) - (y1 - y0) * (n11 - x0)
            mask &= sign * cross >= -1e-9 * span[0] * span[1]
    return n11, opening, mask


def best_efficiency_point(characteristics) -> tuple[float, float, float]:
    """``(eta_best, n11_rpm, opening)``: the highest hydraulic efficiency of ``characteristics`` on a 161 x 161
    grid over their digitized region (see :func:`_search_box`)."""
    from hillchart.characteristics import efficiency_from_characteristics

    n11, opening, mask = _search_box(characteristics)
    with np.errstate(invalid="ignore", divide="ignore"):
        eta = efficiency_from_characteristics(characteristics, n11[mask], opening[mask])
    if not np.any(np.isfinite(eta)):
        raise InputError("turbine.step_up: the characteristics give no finite efficiency in their digitized region; "
                         "give turbine.step_up.model_efficiency_reference")
    i = int(np.nanargmax(eta))
    return float(eta[i]), float(n11[mask][i]), float(opening[mask][i])


@dataclass(frozen=True)
class StepUp:
    """The step-up of one plant: what was assumed and what came out (all JSON-ready floats).

    ``delta_efficiency`` Delta_eta; ``torque_factor`` (eta_hoptM + Delta_eta) / eta_hoptM; ``model_efficiency``
    eta_hoptM and whether it was given or found (``model_efficiency_source``); ``best_n11_rpm`` N11_opt;
    ``model_speed_rpm``/``prototype_speed_rpm`` there; ``reynolds_model``/``reynolds_prototype``.
    """

    method: str
    delta_efficiency: float
    torque_factor: float
    model_efficiency: float
    model_efficiency_source: str
    best_n11_rpm: float
    model_speed_rpm: float
    prototype_speed_rpm: float
    reynolds_model: float
    reynolds_prototype: float

    def as_dict(self) -> dict:
        return {name: getattr(self, name) for name in self.__dataclass_fields__}


def compute_step_up(config: StepUpConfig, characteristics, *, prototype_diameter_m: float,
                    prototype_head_m: float) -> StepUp:
    """Delta_eta and the torque factor for ``characteristics`` (the model) run as a prototype of
    ``prototype_diameter_m`` at ``prototype_head_m`` (see the module docstring)."""
    eta_found, n11_best, _ = best_efficiency_point(characteristics)
    if config.model_efficiency_reference is None:
        eta_ref, source = eta_found, "best efficiency of the characteristics in the digitized region"
    else:
        eta_ref, source = float(config.model_efficiency_reference), "turbine.step_up.model_efficiency_reference"
    n_model = n11_best * math.sqrt(config.model_head_m) / config.model_diameter_m
    n_prototype = n11_best * math.sqrt(prototype_head_m) / prototype_diameter_m
    re_model = float(reynolds_number(config.model_diameter_m, n_model, config.kinematic_viscosity_m2_s))
    re_prototype = float(reynolds_number(prototype_diameter_m, n_prototype, config.kinematic_viscosity_m2_s))
    delta = iec60193_step_up(eta_ref, re_model, re_prototype, scalable_loss_share=config.scalable_loss_share,
                             reynolds_reference=config.reynolds_reference)
    return StepUp(method=config.method, delta_efficiency=delta, torque_factor=(eta_ref + delta) / eta_ref,
                  model_efficiency=eta_ref, model_efficiency_source=source, best_n11_rpm=n11_best,
                  model_speed_rpm=n_model, prototype_speed_rpm=n_prototype, reynolds_model=re_model,
                  reynolds_prototype=re_prototype)


# ------------------------------------------------------------------------------------------------------------------
# the stepped-up characteristics
# ------------------------------------------------------------------------------------------------------------------
class TorqueScaled:
    """Characteristics whose unit torque (and its derivatives) is ``factor`` times that of ``base``; the unit flow
    is ``base``'s. For characteristics other than trained nets (those get the factor in their weights, see
    :func:`scale_torque`). Forwards the attributes the simulator reads for the trusted domain. Without a compiled
    kernel of its own (:class:`TorqueScaledSynthetic` has one) the loop runs the four methods as Python."""

    _FORWARD = ("flow", "torque", "digitized_region", "opening_unit", "opening_max", "training")

    def __init__(self, base, factor: float, step_up: StepUp | None = None):
        self.base, self.factor, self.step_up = base, float(factor), step_up

    def __getattr__(self, name):
        if name in TorqueScaled._FORWARD:
            return getattr(self.base, name)
        raise AttributeError(name)

    def q11(self, n11, opening):
        return self.base.q11(n11, opening)

    def m11(self, n11, opening):
        return self.factor * np.asarray(self.base.m11(n11, opening), float)

    def q11_grad(self, n11, opening):
        return self.base.q11_grad(n11, opening)

    def m11_grad(self, n11, opening):
        return tuple(self.factor * np.asarray(g, float) for g in self.base.m11_grad(n11, opening))

    def efficiency(self, n11, opening):
        from hillchart.characteristics import efficiency_from_characteristics
        return efficiency_from_characteristics(self, n11, opening)

    def members(self) -> list:
        members = self.base.members() if hasattr(self.base, "members") else []
        return [scale_torque(m, self.factor, self.step_up) for m in members]


class TorqueScaledSynthetic(TorqueScaled):
    """:class:`TorqueScaled` over the exact synthetic Francis turbine, with its compiled kernel (the loop runs
    compiled, as with the turbine itself)."""

    def numba_kernel(self):
        """``(kernel, params)`` for the compiled loop: the synthetic kernel with its torque times the factor."""
        from simulate.components.turbine.step_up_kernel import scaled_synthetic_kernel

        _, params = self.base.numba_kernel()
        return scaled_synthetic_kernel, (tuple(params), self.factor)


def scale_torque(characteristics, factor: float, step_up: StepUp | None = None):
    """``characteristics`` with the unit torque multiplied by ``factor`` > 0 (flow unchanged).

    Trained nets (:class:`hillchart.nets.hill_nets.HillNets`) come back as nets whose torque net's output range
    ``[y_min, y_max]`` is scaled (the net's output is affine in it, eq. (11) of the BP hill-chart paper: exact up to
    rounding), ensemble members and the physical model below the lowest digitized line included, with the step-up
    recorded in ``training["step_up"]``; anything else is wrapped in :class:`TorqueScaled`."""
    from hillchart.nets.hill_nets import HillNets
    from hillchart.nets.weights import NetWeights

    if not (math.isfinite(factor) and factor > 0):
        raise InputError(f"the torque factor of the step-up must be finite and > 0, got {factor!r}")
    if not isinstance(characteristics, HillNets):
        from hillchart.synthetic.francis import SyntheticFrancis

        wrapper = TorqueScaledSynthetic if type(characteristics) is SyntheticFrancis else TorqueScaled
        return wrapper(characteristics, factor, step_up)

    def scaled(w: NetWeights) -> NetWeights:
        return NetWeights(x_min=w.x_min, x_max=w.x_max, y_min=factor * w.y_min, y_max=factor * w.y_max, W1=w.W1,
                          b1=w.b1, W2=w.W2, b2=w.b2)

    training = dict(characteristics.training)
    if step_up is not None:
        training["step_up"] = step_up.as_dict()
    silent = characteristics.silent_model
    drawn = characteristics.member_silent_models
    return HillNets(flow=characteristics.flow, torque=scaled(characteristics.torque),
                    opening_unit=characteristics.opening_unit, training=training,
                    ensemble=[(f, scaled(t)) for f, t in characteristics.ensemble],
                    digitized_region=characteristics.digitized_region,
                    silent_model=None if silent is None else silent.scaled(factor),
                    member_silent_models=None if drawn is None else [m.scaled(factor) for m in drawn])


def apply_step_up(characteristics, turbine):
    """The characteristics the prototype runs on: ``characteristics`` unchanged when ``turbine.step_up`` is None,
    else stepped up (:func:`compute_step_up`, :func:`scale_torque`). ``turbine``: the plant's TurbineConfig."""
    config = getattr(turbine, "step_up", None)
    if config is None:
        return characteristics
    from simulate.components.turbine.double_regulated import is_three_input

    if is_three_input(characteristics):
        raise InputError(f"turbine.step_up = {{method = {config.method!r}}} converts a two-input (single-regulated) "
                         f"model chart; turbine.characteristics = {getattr(turbine, 'characteristics', None)!r} has a "
                         f"blade angle (three inputs, double-regulated), for which no step-up is implemented: remove "
                         f"[turbine.step_up]")
    step_up = compute_step_up(config, characteristics, prototype_diameter_m=turbine.runner_diameter_m,
                              prototype_head_m=turbine.rated_head_m)
    return scale_torque(characteristics, step_up.torque_factor, step_up)


def step_up_of(characteristics) -> dict | None:
    """The step-up record of stepped-up characteristics (:meth:`StepUp.as_dict`), or None."""
    if isinstance(characteristics, TorqueScaled):
        return None if characteristics.step_up is None else characteristics.step_up.as_dict()
    training = getattr(characteristics, "training", None)
    return training.get("step_up") if isinstance(training, dict) else None
