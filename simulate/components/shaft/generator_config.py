"""The ``[generator]`` section: the rotor, its load and the machine model (:class:`GeneratorConfig`, every key
declared as data, :mod:`simulate.components.parameters`). ``model`` names the shaft component
(:data:`simulate.components.registry.SHAFTS`): the swing rotor (:mod:`simulate.components.shaft.rotor`) or the
sub-transient machine (:mod:`simulate.components.shaft.generator_shaft`), whose keys are declared by
:class:`simulate.components.electrical.generator.SubtransientGeneratorConfig` and passed on."""

from __future__ import annotations

from dataclasses import dataclass

from hillchart.errors import InputError
from simulate.components.electrical.generator import ElectricalConfig, SubtransientGeneratorConfig
from simulate.components.parameters import borrowed, declarations, parameter, validate_parameters
from simulate.components.registry import SHAFTS

#: Keys of ``[generator]`` that only ``model = "subtransient"`` takes (paper 001 eq. (10), Table 1).
SUBTRANSIENT_KEYS = tuple(d.name for d in declarations(SubtransientGeneratorConfig))


@dataclass(frozen=True)
class GeneratorConfig:
    """Rotor and load: ``inertia_time_s`` Ta = J w_r^2 / P_r; ``self_regulation`` e_g (per unit torque per unit
    speed) of the connected load, active only while the breaker is closed.

    ``model``: the shaft component (registry :data:`simulate.components.registry.SHAFTS`): ``"swing"`` (default, the
    swing equation with load self-regulation) or ``"subtransient"`` (paper 001's machine, eq. (10), with
    ``[excitation]`` and ``[grid]``; its keys :data:`SUBTRANSIENT_KEYS` are required then (``ra`` optional) and
    rejected otherwise; the load's frequency dependence is ``grid.frequency_p``, so ``self_regulation`` must be 0).
    """

    inertia_time_s: float = parameter(unit="s", low=0.0, low_open=True, high=100.0,
                                      description="mechanical starting time T_a = J omega_r^2 / P_r")
    self_regulation: float = parameter(0.0, unit="pu torque/pu speed", low=0.0, high=20.0,
                                       description="load self-regulation e_g while the breaker is closed")
    model: str = parameter("swing", unit="", choices=SHAFTS, description="the shaft component")
    xd: float | None = borrowed(SubtransientGeneratorConfig, "xd")
    xd_t: float | None = borrowed(SubtransientGeneratorConfig, "xd_t")
    xd_st: float | None = borrowed(SubtransientGeneratorConfig, "xd_st")
    xq: float | None = borrowed(SubtransientGeneratorConfig, "xq")
    xq_st: float | None = borrowed(SubtransientGeneratorConfig, "xq_st")
    td0_t_s: float | None = borrowed(SubtransientGeneratorConfig, "td0_t_s")
    td0_st_s: float | None = borrowed(SubtransientGeneratorConfig, "td0_st_s")
    tq0_st_s: float | None = borrowed(SubtransientGeneratorConfig, "tq0_st_s")
    rated_mva: float | None = borrowed(SubtransientGeneratorConfig, "rated_mva")
    power_factor: float | None = borrowed(SubtransientGeneratorConfig, "power_factor")
    ra: float | None = borrowed(SubtransientGeneratorConfig, "ra", description="stator resistance (default 0)")

    def __post_init__(self):
        validate_parameters("generator", self)
        given = [k for k in SUBTRANSIENT_KEYS if getattr(self, k) is not None]
        if self.model != "subtransient":
            if given:
                raise InputError(f"generator.{given[0]} is a key of generator.model = \"subtransient\"; with model = "
                                 f"{self.model!r} the [generator] keys are inertia_time_s, self_regulation, model")
            return
        missing = [k for k in SUBTRANSIENT_KEYS if k != "ra" and getattr(self, k) is None]
        if missing:
            raise InputError(f"missing required key generator.{missing[0]} for generator.model = \"subtransient\"; "
                             f"it needs {', '.join(k for k in SUBTRANSIENT_KEYS if k != 'ra')} (ra optional)")
        if self.self_regulation != 0.0:
            raise InputError(f"generator.self_regulation = {self.self_regulation!r}: with generator.model = "
                             f"\"subtransient\" the load's frequency dependence is grid.frequency_p (island) and the "
                             f"rotor takes the air-gap torque; set self_regulation = 0 or leave it out")
        self.subtransient  # validates the machine (ordering X''d < X'd < Xd, ...)

    @property
    def subtransient(self) -> SubtransientGeneratorConfig:
        """:class:`simulate.components.electrical.generator.SubtransientGeneratorConfig` of the sub-transient keys
        (model "subtransient")."""
        if self.model != "subtransient":
            raise InputError(f"generator.model = {self.model!r} has no sub-transient machine")
        return SubtransientGeneratorConfig(**{k: getattr(self, k) for k in SUBTRANSIENT_KEYS
                                              if getattr(self, k) is not None})


    def electrical(self, excitation, grid) -> ElectricalConfig | None:
        """:class:`simulate.components.electrical.generator.ElectricalConfig` of this section, ``[excitation]`` and
        ``[grid]`` (model "subtransient", which needs both sections; None for the swing model, which takes
        neither)."""
        given = [name for name, section in (("excitation", excitation), ("grid", grid)) if section is not None]
        if self.model != "subtransient":
            if given:
                raise InputError(f"section [{given[0]}] is used only by generator.model = \"subtransient\" (got "
                                 f"generator.model = {self.model!r})")
            return None
        for name in ("excitation", "grid"):
            if name not in given:
                raise InputError(f"missing section [{name}]: generator.model = \"subtransient\" needs [excitation] "
                                 f"and [grid]")
        return ElectricalConfig(generator=self.subtransient, excitation=excitation, grid=grid)

    def rotor_self_regulation(self, grid, load_pu: float) -> float:
        """e_g of the rotor's load (per unit of rated torque per unit speed) at a load of ``load_pu`` (rated torque
        units), for the linear models: ``self_regulation`` with the swing model; with the sub-transient generator on
        an island ``grid.frequency_p * load_pu`` (the air-gap power P0 (1 + frequency_p x) with the voltage held at
        its set point by the excitation, which settles much faster than the rotor). On an infinite bus the rotor
        sees a synchronizing torque, which the linear models do not have: :class:`InputError`."""
        if self.model != "subtransient":
            return self.self_regulation
        if grid.kind != "island":
            raise InputError(f"grid.kind = {grid.kind!r}: the linear turbine models have no synchronizing torque; "
                             f"linearize with grid.kind = 'island' or generator.model = 'swing'")
        return grid.island_frequency_p * float(load_pu)


__all__ = ["SUBTRANSIENT_KEYS", "GeneratorConfig"]
