"""What a run prepares before its loop, for a plant of one unit or of several (``[[units]]``): the characteristics
as the plant uses them, the verified steady state (remembered per characteristics object), the scenario's
schedules and the compiled components of a single-unit plant. The driver (:mod:`simulate.loop.driver`) reads them.
"""

from __future__ import annotations

import threading
import weakref

from hillchart.errors import InputError
from simulate.components.turbine.component import characteristics_of, load_turbine
from simulate.components.turbine.kinds import adopt_characteristics
from simulate.config import PlantConfig
from simulate.loop.common import upstream_friction_s2_m5
from simulate.loop.steady import ManifoldSteadyState, SteadyState, manifold_steady_state, steady_state
from simulate.scenarios import build_schedules, initial_target, steady_schedules


def downstream_friction_s2_m5(plant: PlantConfig) -> float:
    """Steady head loss coefficient K Q|Q| below the runner (a ``[draft_tube]``), s^2/m^5."""
    config = getattr(plant, "draft_tube", None)
    return 0.0 if config is None else config.friction_coefficient_s2_m5


def plant_characteristics(plant: PlantConfig, characteristics):
    """The characteristics as the plant uses them (three-input ones seen through the combinator, see
    :mod:`simulate.components.turbine.double_regulated`); two-input ones unchanged."""
    def count_inputs():
        import inspect

        q11 = getattr(characteristics, "q11", None)
        try:
            return len(inspect.signature(q11).parameters) if q11 is not None else 2
        except (TypeError, ValueError):
            return 2

    inputs = _memo(characteristics, ("inputs",), count_inputs)  # inspect.signature: 0.1 ms a run
    if inputs != 3 and getattr(plant, "combinator", None) is None and getattr(plant, "blade_servo", None) is None:
        return characteristics  # a single-regulated unit: nothing to import
    from simulate.components.turbine.double_regulated import plant_characteristics as view

    return view(plant, characteristics)


#: Per characteristics object (weakly held): the steady states and trusted domains already computed, by their
#: inputs. A batch of cases that share a load case (a sweep of closing times, an optimizer's generations) finds its
#: steady state once; a hit returns the very object a fresh computation would equal bit for bit (the same inputs
#: through the same code).
_MEMO: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()
#: Entries kept per characteristics object before the memo of that object starts again.
MEMO_ENTRIES = 4096
_MEMO_LOCK = threading.Lock()


def _memo(characteristics, key: tuple, compute):
    """``compute()``, remembered per ``characteristics`` (when it can be weakly referenced) by ``key``."""
    try:
        hash(key)
        with _MEMO_LOCK:  # runs on several threads (simulate.loop.parallel)
            table = _MEMO.setdefault(characteristics, {})
    except TypeError:  # not weakly referenceable, or a key that cannot be hashed: nothing remembered
        return compute()
    found = table.get(key)
    if found is None:
        found = compute()
        with _MEMO_LOCK:
            if len(table) >= MEMO_ENTRIES:
                table.clear()
            found = table.setdefault(key, found)
    return found


def initial_state(plant: PlantConfig, characteristics=None) -> SteadyState:
    """The verified steady state a run of ``plant`` starts from (see :mod:`simulate.loop.steady`).

    Examples
    --------
    >>> from simulate.config import load_plant
    >>> import importlib.resources as ir
    >>> plant = load_plant(ir.files("data_synthetic") / "plant_hla339.toml", {"turbine.characteristics": "ideal"})
    >>> s = initial_state(plant)
    >>> round(s.power_mw, 9), s.speed_rpm, max(abs(v) for v in s.residuals.values()) < 1e-9
    (225.0, 200.0, True)
    """
    from hillchart.characteristics import scalar_kernel

    chars = characteristics_of(plant, characteristics)
    view = plant_characteristics(plant, chars)
    friction = plant.penstock.friction_coefficient_s2_m5
    extra = upstream_friction_s2_m5(plant)
    if extra:
        friction = friction + extra
    below = downstream_friction_s2_m5(plant)
    if below:
        friction = friction + below
    target = initial_target(plant.scenario)
    inputs = ("steady", plant.turbine, plant.penstock.static_head_m, friction, plant.governor.stroke_min,
              plant.governor.stroke_max, tuple(sorted(target.items())))

    def compute():
        # a double-regulated unit: values at the cam through the compiled kernel (the steady state reads no
        # derivative)
        kernel, params = view.steady_kernel() if hasattr(view, "steady_kernel") else scalar_kernel(view)[:2]
        return steady_state(kernel, params, turbine=plant.turbine, static_head_m=plant.penstock.static_head_m,
                            friction_s2_m5=friction, stroke_min=plant.governor.stroke_min,
                            stroke_max=plant.governor.stroke_max, **target)

    try:
        return _memo(view, inputs, compute)
    except InputError as exc:  # a value in another unit than the chart is the likelier cause: say so
        from simulate.loop.guards import characteristics_warnings

        hints = characteristics_warnings(plant.turbine, chars)
        if not hints:
            raise
        raise InputError(f"{exc}. Note: {'. Note: '.join(hints)}") from None


def plant_schedules(plant: PlantConfig, steady: SteadyState):
    """The scenario's schedules from the steady state ``steady``."""
    return build_schedules(plant, steady.stroke, steady.torque_nm / plant.turbine.rated_torque_nm)


def build_parts(plant: PlantConfig, steady: SteadyState, dt_s: float, substeps: int = 1,
                characteristics=None, schedules=None) -> dict:
    """The compiled components of ``plant`` by kind (penstock, upstream, control, shaft, downstream), from the
    registries, and the scenario's schedules (``schedules``: those of :func:`plant_schedules`, when the caller has
    them). Control and shaft are built for the sub-step ``dt_s / substeps`` (see :mod:`simulate.loop.timestep`).
    ``characteristics``: those the run uses (default the plant's own, :func:`simulate.components.turbine.component.
    characteristics_of`); a double-regulated unit's blade control reads their plant view's cam."""
    from simulate.components.registry import (CONTROLS, DOWNSTREAM, PENSTOCKS, SHAFTS, UPSTREAM, control_name,
                                              downstream_section, shaft_section, upstream_section)

    schedules = plant_schedules(plant, steady) if schedules is None else schedules
    sub_dt = dt_s / substeps
    upstream = UPSTREAM.builder(upstream_section(plant)[0])(plant, steady, dt_s)
    head0 = upstream.hooks.initial_head_m
    head0 = plant.penstock.static_head_m if head0 is None else head0
    parts = {
        "upstream": upstream,
        "penstock": PENSTOCKS.builder(plant.penstock.model)(plant, steady, dt_s, head0),
        "shaft": SHAFTS.builder(shaft_section(plant)[0])(plant, steady, sub_dt, schedules),
        "downstream": DOWNSTREAM.builder(downstream_section(plant)[0])(plant, steady, dt_s),
    }
    control = control_name(plant, schedules)
    extra = {"characteristics": plant_characteristics(plant, characteristics_of(plant, characteristics))} \
        if control.endswith("_blades") else {}
    parts["control"] = CONTROLS.builder(control)(plant, steady, sub_dt, schedules, **extra)
    return parts, schedules


def unit_characteristics(plant: PlantConfig, characteristics=None) -> list:
    """The characteristics of every unit as the unit uses them (``characteristics`` for all when given, else each
    unit's ``turbine.characteristics``; three-input ones seen through the plant's combinator, see
    :func:`plant_characteristics`). Units with the same turbine section share one object."""
    return [chars for chars, _ in unit_turbines(plant, characteristics)]


def unit_turbines(plant: PlantConfig, characteristics=None) -> list[tuple]:
    """``(characteristics as the unit uses them, kind)`` of every unit (:func:`unit_characteristics`); ``kind``:
    the registry word of the characteristics' kind (for the caller's ``characteristics``: of the kind that adopts
    them, None when none does, :func:`simulate.components.turbine.kinds.adopt_characteristics`)."""
    loaded: dict = {}
    out = []
    given = None if characteristics is None else adopt_characteristics(characteristics)
    for unit in plant.units:
        key = (id(characteristics), unit.turbine)
        if key not in loaded:
            own = load_turbine(unit.turbine, plant.base_dir) if given is None else None
            kind, raw = given if own is None else (own.kind, own.characteristics)
            try:
                loaded[key] = (plant_characteristics(plant.unit_plant(unit), raw), kind)
            except InputError as exc:
                raise InputError(f"unit {unit.name!r}: {exc}") from None
        out.append(loaded[key])
    return out


def units_initial_state(plant: PlantConfig, characteristics: list) -> ManifoldSteadyState:
    """The verified steady state of every unit with the common conduit's loss of the summed flow (see
    :func:`simulate.loop.steady.manifold_steady_state`); ``characteristics``: each unit's, as
    :func:`unit_characteristics` gives them. A unit's own loss is its branch's and its draft tube's."""
    from hillchart.characteristics import scalar_kernel

    units = []
    for unit, chars in zip(plant.units, characteristics):
        # a double-regulated unit: values at the cam through the compiled kernel (the steady state reads no
        # derivative), as for a plant of one unit (initial_state)
        kernel, params = chars.steady_kernel() if hasattr(chars, "steady_kernel") else scalar_kernel(chars)[:2]
        view = plant.unit_plant(unit)
        units.append(dict(name=unit.name, kernel=kernel, params=params, turbine=unit.turbine,
                          branch_friction_s2_m5=view.penstock.friction_coefficient_s2_m5
                          + downstream_friction_s2_m5(view),
                          stroke_min=unit.governor.stroke_min, stroke_max=unit.governor.stroke_max,
                          **initial_target(view.scenario)))
    friction = plant.penstock.friction_coefficient_s2_m5 + upstream_friction_s2_m5(plant)
    try:
        return manifold_steady_state(units, static_head_m=plant.penstock.static_head_m, friction_s2_m5=friction)
    except InputError as exc:
        raise InputError(f"{exc} (the scenario's initial point is each unit's; set units.initial_power_mw or "
                         f"units.initial_opening of a unit for its own)") from None


def unit_schedules(plant: PlantConfig, steady: ManifoldSteadyState) -> list:
    """Each unit's schedules: the scenario's for the units of ``scenario.units`` (default all), an undisturbed unit
    on its load under its governor for the others."""
    out = []
    events = set(plant.event_units)
    for unit, st in zip(plant.units, steady.units):
        view = plant.unit_plant(unit)
        load = st.torque_nm / unit.turbine.rated_torque_nm
        out.append(build_schedules(view, st.stroke, load) if unit.name in events
                   else steady_schedules(view, st.stroke, load))
    return out
