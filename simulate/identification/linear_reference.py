"""The linear model the nets predict at a plant's operating point: the reference identification is compared with.

:func:`linear_reference` gives the six coefficients (:func:`hillchart.linearize.six_coefficients`) and the
:class:`simulate.linear.models.LinearPlant` at a verified steady state; :func:`plant_linearization` is the same at a
plant's initial operating point, as JSON-ready numbers (``hillsim linearize --plant``, the demo's
``linearization.json``).

The linear plant is composed from the components' declared linear counterparts
(:meth:`simulate.components.registry.Registry.contract`): the penstock model's block (the water time Tw, the friction
slope r_f and, with waves, Te and alpha: :mod:`simulate.components.hydraulic.penstock`) and the shaft's (the rotor's
J and e_g in paper 000's increments: :mod:`simulate.components.shaft.rotor`); their numbers are the keyword arguments
of :meth:`simulate.linear.models.LinearPlant.from_coefficients`. The plant's upstream and downstream levels are
constant in that model (a surge tank declares its linearized block, which the model does not take).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from hillchart.errors import InputError
from hillchart.linearize import six_coefficients
from simulate.components.registry import PENSTOCKS, SHAFTS, shaft_section
from simulate.identification.results import CoefficientSet, optional
from simulate.linear.models import LinearPlant


def linear_reference(plant, characteristics, steady, *, penstock_model: str | None = None):
    """``(coefficients, LinearPlant)`` the nets predict at the steady state of a plant (see module docstring).

    Parameters
    ----------
    plant : simulate.config.PlantConfig
    characteristics : Characteristics
        The nets (or any characteristics) the simulator uses; three-input ones are read on the plant's cam.
    steady : simulate.loop.steady.SteadyState
        Verified initial state of the run.
    penstock_model : str, optional
        ``"rigid"`` gives the inelastic model (eqs. 10-12); anything else the lumped elastic model (eqs. 24-30) with
        Te = sum L/a and the plant's lumped_alpha. Default: the plant's own model.
    """
    from simulate.loop.engine import plant_characteristics

    turbine = plant.turbine
    n11 = steady.speed_rpm * turbine.runner_diameter_m / math.sqrt(steady.head_m)  # N11 = n D1 / sqrt(H)
    # as the plant sees them: a double-regulated unit's on its cam (the blades follow the vanes), over the plant's
    # opening, so the coefficients are those of the unit its governor moves
    coeffs = six_coefficients(plant_characteristics(plant, characteristics), n11=n11, opening=steady.opening_chart)
    blocks = (PENSTOCKS.linear_counterpart(penstock_model or plant.penstock.model, plant, steady),
              SHAFTS.linear_counterpart(shaft_section(plant)[0], plant, steady))
    parameters = {}
    for block in blocks:
        for name, value in block.values.items():
            if name in parameters:
                raise TypeError(f"{name} of the linear plant is given by two components' blocks ({block.equation})")
            parameters[name] = value
    linear = LinearPlant.from_coefficients(coeffs, **parameters)
    return coeffs, linear


@dataclass(frozen=True)
class LinearizationPoint:
    """The plant's verified initial operating point and its chart coordinates (opening in chart units)."""

    speed_rpm: float
    head_m: float
    flow_m3_s: float
    torque_nm: float
    power_mw: float
    stroke: float
    opening_chart: float
    n11_rpm: float


@dataclass(frozen=True)
class SpeedTransferFunction:
    """x/y = N(s)/D(s), coefficients in descending powers of s (paper 000 eqs. 43-44, 51-52)."""

    num: tuple[float, ...]
    den: tuple[float, ...]


@dataclass(frozen=True)
class ArxCoefficients:
    """The ARX model of the zero-order hold at ``sample_time_s`` (paper 000 eqs. 32-36, 53)."""

    a: tuple[float, ...]
    b: tuple[float, ...]
    input_delay: int
    sample_time_s: float


@dataclass(frozen=True)
class LinearModel:
    """The nets' linear plant: its parameters, the eigenvalues of A (1/s; ``[re, im]`` in JSON), open-loop
    stability, the speed transfer function and the ARX at tau."""

    kind: str
    water_time_s: float
    inertia_time_s: float
    self_regulation: float
    wave_time_s: float
    alpha: float
    friction_slope: float
    eigenvalues: tuple[complex, ...]
    open_loop_stable: bool
    speed_tf: SpeedTransferFunction
    arx: ArxCoefficients


@dataclass(frozen=True)
class PlantLinearization:
    """:func:`plant_linearization`'s result (``hillsim linearize --plant``, the demo's ``linearization.json`` via
    :func:`simulate.identification.results.to_json_dict`); ``coefficients_exact``: the exact turbine's, when the
    caller adds them."""

    operating_point: LinearizationPoint
    coefficients: CoefficientSet
    e: float
    linear_model: LinearModel
    coefficients_exact: CoefficientSet | None = optional()


def plant_linearization(plant, characteristics=None, *, initial_opening: float | None = None,
                        penstock_model: str | None = None, sample_time_s: float = 0.2) -> PlantLinearization:
    """The nets' linear model at a plant's verified initial operating point.

    Operating point: ``initial_opening`` (stroke fraction) or the plant scenario's initial power/opening. Returns
    the operating point, the six coefficients, the linear-plant parameters (Tw, J, e_g, Te, alpha, r_f), the
    eigenvalues of A and open-loop stability, the speed transfer function N/D and the ARX at ``sample_time_s``.
    """
    from dataclasses import replace as _replace

    from simulate.components.turbine.component import characteristics_of
    from simulate.config import ScenarioConfig
    from simulate.loop.engine import initial_state

    chars = characteristics_of(plant, characteristics)
    if initial_opening is not None:
        plant = _replace(plant, scenario=ScenarioConfig(kind="opening-steps", t_end_s=10.0,
                                                        initial_opening=initial_opening))
    elif plant.scenario.kind == "frequency-steps":
        raise InputError("the plant's scenario is frequency-steps (no load): give an initial opening")
    steady = initial_state(plant, chars)
    coeffs, linear = linear_reference(plant, chars, steady, penstock_model=penstock_model)
    ss = linear.state_space()
    num, den = linear.speed_transfer_function()
    arx = linear.arx(sample_time_s)
    return PlantLinearization(
        operating_point=LinearizationPoint(
            speed_rpm=steady.speed_rpm, head_m=steady.head_m, flow_m3_s=steady.flow_m3_s, torque_nm=steady.torque_nm,
            power_mw=steady.power_mw, stroke=steady.stroke, opening_chart=steady.opening_chart,
            n11_rpm=coeffs.n11_rpm),
        coefficients=CoefficientSet.of(coeffs),
        e=coeffs.e,
        linear_model=LinearModel(
            kind="elastic (lumped, eqs. 24-30)" if linear.elastic else "inelastic (eqs. 10-12)",
            water_time_s=linear.water_time_s, inertia_time_s=linear.inertia_time_s,
            self_regulation=linear.self_regulation, wave_time_s=linear.wave_time_s, alpha=linear.alpha,
            friction_slope=linear.friction_slope,
            eigenvalues=tuple(complex(float(v.real), float(v.imag)) for v in ss.eigenvalues()),
            open_loop_stable=ss.is_stable(),
            speed_tf=SpeedTransferFunction(num=tuple(num.tolist()), den=tuple(den.tolist())),
            arx=ArxCoefficients(a=tuple(float(v) for v in arx.a), b=tuple(float(v) for v in arx.b),
                                input_delay=int(arx.input_delay), sample_time_s=float(arx.sample_time_s))),
    )
