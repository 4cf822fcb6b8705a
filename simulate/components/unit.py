"""One unit of a plant with several units (``[[units]]``, :class:`UnitConfig`): its branch pipe from the manifold,
its turbine, generator and governor. A unit composes the components' sections, so it sits at the top of the
components package (the reader, :mod:`simulate.config`, is a layer above; the junction that joins the branches is
:mod:`simulate.components.hydraulic.junction`)."""

from __future__ import annotations

from dataclasses import dataclass, replace

from hillchart.errors import InputError
from hillchart.validation import check_number
from simulate.components.control.governor import GovernorConfig
from simulate.components.hydraulic.conduit import PenstockConfig, PenstockSegment, read_segments
from simulate.components.parameters import parameter, validate_parameters
from simulate.components.registry import PENSTOCKS
from simulate.components.shaft.generator_config import GeneratorConfig
from simulate.components.turbine.rated import TurbineConfig

#: Sections of the plant a unit may override, key by key (``[units.turbine]`` ...).
UNIT_OVERRIDE_SECTIONS = ("turbine", "generator", "governor")


@dataclass(frozen=True)
class UnitConfig:
    """One unit of a plant with several units (``[[units]]``): its branch from the manifold at the downstream end of
    ``[penstock]`` (the common conduit) to its turbine, and its turbine, generator and governor.

    ``name``: the unit's name in the output columns (``U1.speed_rpm``) and in ``scenario.units``: letters, digits,
    ``_`` and ``-``. ``branch``: the pipe segments from the manifold to the turbine (``[[units.branch]]``, the keys of
    ``[[penstock.segments]]``, upstream first), computed by the method of characteristics on the plant's grid.
    ``[units.turbine]``, ``[units.generator]``, ``[units.governor]`` (optional): keys that differ from the plant's
    ``[turbine]``, ``[generator]``, ``[governor]`` for this unit (the resolved sections are stored here).
    ``initial_power_mw`` / ``initial_opening`` (optional): this unit's initial point instead of the scenario's.
    """

    name: str = parameter(unit="", kind="text", what="a non-empty name of letters, digits, _ and -",
                          description="the unit's name in the output columns and in scenario.units")
    branch: tuple[PenstockSegment, ...] = parameter(unit="", kind="array",
                                                    what="a non-empty array of tables [[units.branch]]",
                                                    description="the pipes from the manifold, upstream first")
    turbine: TurbineConfig = parameter(unit="", kind="table", table=TurbineConfig,
                                       description="this unit's keys of [turbine] ([units.turbine])")
    generator: GeneratorConfig = parameter(unit="", kind="table", table=GeneratorConfig,
                                           description="this unit's keys of [generator] ([units.generator])")
    governor: GovernorConfig = parameter(unit="", kind="table", table=GovernorConfig,
                                         description="this unit's keys of [governor] ([units.governor])")
    initial_power_mw: float | None = parameter(None, unit="MW", low=0.0, high=3000.0,
                                               description="this unit's initial power (at most 1.5 x its rating)")
    initial_opening: float | None = parameter(None, unit="stroke fraction", low=0.0, high=1.5,
                                              description="this unit's initial stroke (within its stroke limits)")

    def __post_init__(self):
        validate_parameters("units", self)
        if not all(c.isalnum() or c in "_-" for c in self.name):
            raise InputError(f"units.name must be a non-empty name of letters, digits, _ and -, got {self.name!r}")
        try:
            object.__setattr__(self, "branch", read_segments(self.branch, "units.branch"))
        except InputError as exc:
            raise InputError(f"{exc} (unit {self.name!r})") from None
        if self.initial_power_mw is not None and self.initial_opening is not None:
            raise InputError(f"unit {self.name!r}: give at most one of units.initial_power_mw and "
                             f"units.initial_opening, got {self.initial_power_mw!r} and {self.initial_opening!r}")
        if self.initial_power_mw is not None:
            check_number(f"units.initial_power_mw (unit {self.name!r})", self.initial_power_mw, low=0.0,
                         high=1.5 * self.turbine.rated_power_mw)
        if self.initial_opening is not None:
            check_number(f"units.initial_opening (unit {self.name!r})", self.initial_opening,
                         low=self.governor.stroke_min, high=self.governor.stroke_max)
        if self.generator.model != "swing":
            raise InputError(f"unit {self.name!r}: generator.model = {self.generator.model!r}; a plant with "
                             f"[[units]] takes generator.model = \"swing\" (one machine per unit on its own load)")

    def branch_penstock(self, penstock: PenstockConfig) -> PenstockConfig:
        """The branch as a MOC :class:`PenstockConfig`: the common conduit's section (its ``reaches``, every other
        key passed on) with the branch's pipes; the manifold head is its upstream head."""
        return replace(penstock, model="moc", segments=self.branch)


def check_units(plant) -> None:
    """The ``[[units]]`` of ``plant`` (:class:`simulate.config.PlantConfig`) against the rest of the plant: names
    unique, ``scenario.units`` known, a conduit that computes branches, swing units, no fixed step;
    a plant without units has no ``scenario.units``."""
    sc = plant.scenario
    if not plant.units:
        if sc.units is not None:
            raise InputError(f"scenario.units = {list(sc.units)!r} needs a plant with [[units]]; this plant has "
                             f"one unit (leave scenario.units out)")
        return
    names = [u.name for u in plant.units]
    duplicate = sorted({n for n in names if names.count(n) > 1})
    if duplicate:
        raise InputError(f"units.name {duplicate[0]!r} is given twice; unit names must be unique, got {names!r}")
    for name in sc.units or ():
        if name not in names:
            raise InputError(f"scenario.units names {name!r}, which is not a unit of this plant; the units are "
                             f"{', '.join(names)}")
    if not PENSTOCKS.traits(plant.penstock.model).computes_branches:
        raise InputError(f"penstock.model = {plant.penstock.model!r}: a plant with [[units]] computes the common "
                         f"conduit and the branches by the method of characteristics; set penstock.model = "
                         f"\"moc\"")
    for key in plant.penstock.unread_keys():  # no linear reference of a plant of several units reads it either
        raise InputError(f"penstock.{key} = {getattr(plant.penstock, key)!r}: a plant with [[units]] computes its "
                         f"conduit by the method of characteristics, which does not read it; remove the key")
    if plant.generator.model != "swing":
        raise InputError(f"generator.model = {plant.generator.model!r}: a plant with [[units]] takes "
                         f"generator.model = \"swing\"")
    if plant.solver.dt_s is not None:
        raise InputError(f"solver.dt_s = {plant.solver.dt_s!r}: a plant with [[units]] steps on the grid of its "
                         f"pipes ((shortest travel time) / penstock.reaches); leave solver.dt_s out")
    if sc.initial_power_mw is not None:
        for u in plant.units:
            if u.initial_power_mw is None and u.initial_opening is None \
                    and sc.initial_power_mw > 1.5 * u.turbine.rated_power_mw:
                raise InputError(f"scenario.initial_power_mw = {sc.initial_power_mw!r} is each unit's initial "
                                 f"power; unit {u.name!r} is rated {u.turbine.rated_power_mw!r} MW (at most "
                                 f"1.5 x that): set units.initial_power_mw of that unit")


#: Keys of one ``[[units]]`` table.
UNIT_KEYS = tuple(f for f in UnitConfig.__dataclass_fields__)

__all__ = ["UNIT_OVERRIDE_SECTIONS", "UNIT_KEYS", "UnitConfig", "check_units"]
