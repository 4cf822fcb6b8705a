"""What the single-unit loop (:mod:`simulate.loop.engine`) and the loop of several units
(:mod:`simulate.loop.multi_unit`) share: the turbine boundary's limits, the advice of a failed pressure loop (its
text is the boundary's, :mod:`simulate.components.turbine.boundary`), the chunking of the compiled loop and the
steady loss upstream of the penstock."""

from __future__ import annotations

from simulate.components.turbine.boundary import (  # noqa: F401  (the pressure loop's advice, re-exported)
    FAILURE_ADVICE, SEPARATION_ADVICE, SEPARATION_FRACTION, _failure_advice)

#: Lowest head (fraction of rated) the pressure loop accepts; below it the column would separate.
HEAD_FLOOR_FRACTION = 1e-4
#: Stroke at or below which the guide vanes are shut: the boundary is a closed valve, Q = 0 and H = C_L, whatever
#: the characteristics say. A fitted net has a small Q11 at a = 0 (the shipped nets: about -0.002 m^3/s, varying
#: with N11); with dQ/dH < 0 that "leak" is a negative resistance that pumps the water hammer in a shut penstock.
#: The servo approaches its end stop exponentially, so "shut" is 1e-6 of the stroke, not exactly 0.
CLOSED_STROKE = 1e-6

#: Wall time of work per call into the compiled loop; Ctrl-C is honoured between calls.
CHUNK_WALL_S = 0.25


def step_count(t_end_s: float, dt_s: float) -> int:
    """Steps of a run of ``t_end_s`` on the step ``dt_s``; at least one, else an error naming scenario.t_end_s."""
    from hillchart.errors import InputError

    n_steps = int(round(t_end_s / dt_s))
    if n_steps < 1:
        raise InputError(f"scenario.t_end_s = {t_end_s!r} is shorter than one step (dt = {dt_s:.6g} s)")
    return n_steps


def run_in_chunks(loop, args: tuple, n_steps: int, dt_s: float, n_sub: int, stride: int, progress=None):
    """Run the compiled ``loop(k0, k1, dt, n_sub, stride, *args)`` over steps 0 .. n_steps-1 in chunks of about
    :data:`CHUNK_WALL_S` of work (a multiple of the output ``stride``), calling ``progress(k, n_steps)`` between
    them. Returns ``(status, k_done, wall_s)``: the loop's status (0, or the failure), the step it stopped at and
    the wall time."""
    import time

    start = time.perf_counter()
    k, status, k_done = 0, 0, 0
    chunk = max(stride, min(n_steps, 2000 // stride * stride or stride))
    while k < n_steps:
        k_end = min(n_steps, k + chunk)
        t0 = time.perf_counter()
        status, k_done = loop(k, k_end, dt_s, n_sub, stride, *args)
        if status != 0:
            break
        k = k_done
        if progress is not None:
            progress(k, n_steps)
        spent = time.perf_counter() - t0
        target = int(chunk * CHUNK_WALL_S / max(spent, 1e-6))
        chunk = max(stride, min(10 * chunk, target) // stride * stride)
    return status, k_done, time.perf_counter() - start


def upstream_friction_s2_m5(plant) -> float:
    """Steady head loss coefficient K Q|Q| upstream of the penstock (e.g. a surge tank's headrace tunnel), s^2/m^5."""
    from simulate.components.registry import upstream_section

    config = upstream_section(plant)[1]
    return 0.0 if config is None else config.steady_loss_coefficient_s2_m5
