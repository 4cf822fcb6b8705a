"""The ``[turbine]`` section: the unit's rated values and where its characteristics come from
(:class:`TurbineConfig`, every key declared as data, :mod:`simulate.components.parameters`). The characteristics
themselves are the registry's (:data:`simulate.components.registry.CHARACTERISTICS`); the turbine boundary that
uses them is :mod:`simulate.components.turbine.boundary`."""

from __future__ import annotations

from dataclasses import dataclass

from hillchart.constants import G_M_S2, RHO_WATER_KG_M3, RPM_TO_RAD_S
from hillchart.errors import InputError
from simulate.components.parameters import parameter, validate_parameters
from simulate.components.turbine.step_up import StepUpConfig


@dataclass(frozen=True)
class TurbineConfig:
    """Rated values of the unit and where its characteristics come from.

    ``opening_max`` is the chart opening (chart units, e.g. mm) at full servo stroke y = 1, so the chart opening is
    ``a = y * opening_max``. ``characteristics`` is ``"ideal"``, ``"synthetic"`` (the exact synthetic Francis),
    ``"synthetic-bulb"`` (the exact synthetic double-regulated bulb), ``"synthetic-pump-turbine"`` (the exact synthetic
    pump-turbine, four quadrants) or a path to a nets.json (relative to the plant file; Suter-curve nets and
    tabulated Suter curves are four-quadrant too); characteristics with a blade angle (three-input nets, the bulb)
    need ``[combinator]``.
    ``operating_mode``: ``"pump"`` starts the run pumping, at the speed -n_r in hillsim's turbine-positive
    convention (flow < 0, head > 0, torque > 0; :mod:`simulate.components.turbine.four_quadrant`): only
    characteristics over all four quadrants have a pump mode.
    ``step_up``: the table ``[turbine.step_up]`` when the chart is a model test to be converted to this prototype
    (IEC 60193 efficiency step-up, see below); absent, the characteristics are used as they are.
    """

    rated_head_m: float = parameter(unit="m", low=0.0, low_open=True, high=3000.0, description="rated net head H_r")
    rated_flow_m3_s: float = parameter(unit="m^3/s", low=0.0, low_open=True, high=1e4, description="rated flow Q_r")
    rated_speed_rpm: float = parameter(unit="rpm", low=0.0, low_open=True, high=3600.0,
                                       description="rated speed n_r")
    rated_power_mw: float = parameter(unit="MW", low=0.0, low_open=True, high=2000.0,
                                      description="rated power P_r (the per-unit torque base with n_r)")
    runner_diameter_m: float = parameter(unit="m", low=0.0, low_open=True, high=20.0,
                                         description="runner diameter D_1 (the unit quantities' diameter)")
    opening_max: float = parameter(unit="chart opening", low=0.0, low_open=True, high=1e5,
                                   description="chart opening at full servo stroke")
    characteristics: str = parameter(unit="", kind="text", what='"ideal" or a path to a nets.json',
                                     description="the characteristics: a registered name or a nets.json path "
                                                 "(relative to the plant file)")
    operating_mode: str = parameter("turbine", unit="", choices=("turbine", "pump"),
                                    description="the mode at t = 0: turbine (speed +n_r) or pump (speed -n_r, "
                                                "turbine-positive signs; four-quadrant characteristics only)")
    step_up: StepUpConfig | None = parameter(None, unit="", kind="table", table=StepUpConfig,
                                             what='a table such as {method = "iec60193"}',
                                             description="the model-to-prototype step-up, [turbine.step_up]")

    def __post_init__(self):
        if isinstance(self.step_up, (dict, str)):  # the TOML table, or --set turbine.step_up=iec60193
            raw = {"method": self.step_up} if isinstance(self.step_up, str) else self.step_up
            object.__setattr__(self, "step_up", StepUpConfig.from_toml(raw))
        validate_parameters("turbine", self)
        efficiency = self.rated_efficiency
        if not (0.0 < efficiency <= 1.0):
            ratio = "P_r/(rho g Q_r H_r)"
            raise InputError(
                f"turbine.rated_power_mw = {self.rated_power_mw!r} gives a rated efficiency {ratio} = "
                f"{efficiency:.4g}, which must be in (0, 1]; check rated_power_mw, rated_flow_m3_s, rated_head_m")

    @property
    def initial_speed_rpm(self) -> float:
        """The speed of the steady state at t = 0, r/min: n_r in turbine mode, -n_r in pump mode."""
        return -self.rated_speed_rpm if self.operating_mode == "pump" else self.rated_speed_rpm

    @property
    def rated_efficiency(self) -> float:
        """P_r / (rho g Q_r H_r), fraction; in pump mode, when P_r is above rho g Q_r H_r (the rated values are a
        pump's point, P_r its shaft power), the pump's (rho g Q_r H_r) / P_r."""
        hydraulic = RHO_WATER_KG_M3 * G_M_S2 * self.rated_flow_m3_s * self.rated_head_m
        if self.operating_mode == "pump" and self.rated_power_mw * 1e6 > hydraulic:
            return hydraulic / (self.rated_power_mw * 1e6)
        return self.rated_power_mw * 1e6 / hydraulic

    @property
    def rated_torque_nm(self) -> float:
        """P_r / omega_r, N*m (the per-unit torque base of the rotor equation)."""
        return self.rated_power_mw * 1e6 / (self.rated_speed_rpm * RPM_TO_RAD_S)


#: ``combinator.head_m`` may lie from this[0] x ``turbine.rated_head_m`` to this[1] x ``penstock.static_head_m``.
COMBINATOR_HEAD_RANGE = (0.25, 1.5)


def check_combinator_head(combinator, turbine: TurbineConfig, penstock) -> None:
    """``combinator.head_m`` (when the plant has a combinator that sets it) within the plant's heads: from a quarter
    of the rated head (a low-head unit at flood) to 1.5 x the static head (the gross head, which the net head stays
    below)."""
    head = getattr(combinator, "head_m", None)
    if head is None:
        return
    low, high = COMBINATOR_HEAD_RANGE[0] * turbine.rated_head_m, COMBINATOR_HEAD_RANGE[1] * penstock.static_head_m
    if not low <= head <= high:
        raise InputError(f"combinator.head_m = {head!r} m is outside this plant's heads (turbine.rated_head_m = "
                         f"{turbine.rated_head_m!r} m, penstock.static_head_m = {penstock.static_head_m!r} m); "
                         f"allowed [{low:.4g}, {high:.4g}] m ({COMBINATOR_HEAD_RANGE[0]:g} x the rated head "
                         f"to {COMBINATOR_HEAD_RANGE[1]:g} x the static head): give the net head in m of this "
                         f"plant, or leave head_m out (the net head of the initial steady state)")


__all__ = ["COMBINATOR_HEAD_RANGE", "TurbineConfig", "check_combinator_head"]
