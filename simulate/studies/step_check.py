"""Step convergence as a tool: rerun a plant at half the step it ran with and report the change of each summary
figure (``hillsim run --check-step``), so a result can be shown to be converged."""

from __future__ import annotations

from dataclasses import replace

from simulate.components.registry import PENSTOCKS
from simulate.config import MAX_REACHES
from simulate.loop.engine import run_simulation


#: Summary figures compared by :func:`check_step`: per-unit fractions (their change in points of percent) and the
#: figures in physical units (their change in that unit).
STEP_CHECK_FRACTIONS = ("max_speed_rise", "max_head_rise", "min_head_drop", "final_speed_error")
STEP_CHECK_VALUES = (("max_head_m", "m"), ("min_head_m", "m"), ("t_max_speed_s", "s"), ("t_max_head_s", "s"))


def halved_step_plant(plant, dt_s: float):
    """``plant`` at half the step ``dt_s`` it ran with: twice ``penstock.reaches`` for MOC (the grid fixes the
    step), ``solver.dt_s`` = dt / 2 otherwise."""
    if PENSTOCKS.traits(plant.penstock.model).grid_fixes_time_step:
        return replace(plant, penstock=replace(plant.penstock, reaches=2 * plant.penstock.reaches))
    return replace(plant, solver=replace(plant.solver, dt_s=0.5 * dt_s))


def check_halving_allowed(plant) -> None:
    """An :class:`InputError`, before any run, when the half-step rerun of ``plant`` would be refused: for MOC,
    twice ``penstock.reaches`` above its largest allowed value (the message says what to set)."""
    from hillchart.errors import InputError

    if not PENSTOCKS.traits(plant.penstock.model).grid_fixes_time_step:
        return  # solver.dt_s / 2 is always allowed (any dt_s > 0)
    try:
        halved_step_plant(plant, plant.time_step_s)
    except InputError as exc:
        half_max = MAX_REACHES // 2
        raise InputError(f"--check-step reruns at half the step, with penstock.reaches = "
                         f"{2 * plant.penstock.reaches} (twice {plant.penstock.reaches}), which is refused ({exc}); "
                         f"set penstock.reaches <= {half_max} to check the step, or drop --check-step") from None


def check_step(plant, result) -> dict:
    """Rerun ``plant`` at half the step of ``result`` (on the characteristics ``result`` ran on) and compare the
    summary figures.

    Returns ``{"dt_s", "half_dt_s", "figures": {name: {"value", "half_step", "change", "unit"}}, "max_change_points"}``
    with the change of the per-unit figures in points of percent (``unit`` = ``"points"``).

    Examples
    --------
    >>> from simulate.config import load_plant
    >>> from simulate.loop.engine import run_simulation
    >>> import importlib.resources as ir
    >>> plant = load_plant(ir.files("data_synthetic") / "plant_hla339.toml",
    ...                    {"turbine.characteristics": "ideal", "scenario.t_end_s": 10.0})
    >>> check = check_step(plant, run_simulation(plant))
    >>> check["max_change_points"] < 0.1
    True
    """
    dt = float(result.meta["dt_s"])
    half = run_simulation(halved_step_plant(plant, dt), characteristics=result.characteristics)
    a, b = result.summary(), half.summary()
    figures = {}
    for name in STEP_CHECK_FRACTIONS:
        figures[name] = {"value": a[name], "half_step": b[name], "change": 100.0 * (b[name] - a[name]),
                         "unit": "points"}
    for name, unit in STEP_CHECK_VALUES:
        figures[name] = {"value": a[name], "half_step": b[name], "change": b[name] - a[name], "unit": unit}
    worst = max(abs(figures[name]["change"]) for name in STEP_CHECK_FRACTIONS)
    return {"dt_s": dt, "half_dt_s": float(half.meta["dt_s"]), "figures": figures, "max_change_points": worst}
