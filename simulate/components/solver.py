"""The ``[solver]`` section: the time step, the stored output and the pressure loop that solves the turbine boundary
(:class:`SolverConfig`, every key declared as data, :mod:`simulate.components.parameters`).

It lives with the components, not with the loop that reads it: :mod:`simulate.config` composes every section and
sits below :mod:`simulate.loop` in the layers (``tests/test_architecture.py``), so a section's class must come from
a layer below the reader; the pressure loops it names are the turbine boundary's solvers
(:data:`simulate.components.turbine.boundary.SOLVERS`), and the step and output keys belong to no single component,
so the class sits at the top of the components package, beside the other pieces every component shares
(:mod:`simulate.components.timescale`, :mod:`simulate.components.schedules`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from hillchart.errors import InputError
from simulate.components.parameters import parameter, validate_parameters
from simulate.components.turbine.boundary import ROUNDOFF_TOLERANCE, SOLVERS

#: The pressure loops (``solver.pressure_loop``): the turbine boundary's solvers.
PRESSURE_LOOPS = tuple(SOLVERS)
#: The smallest ``solver.tolerance``: the turbine boundary accepts a head within max(tolerance x rated head,
#: :data:`simulate.components.turbine.boundary.ROUNDOFF_TOLERANCE` x (|C_L| + |k Q|)), and |C_L| is about the head.
TOLERANCE_FLOOR = ROUNDOFF_TOLERANCE
#: Relative tolerance of ``solver.dt_s`` against the MOC step (shortest travel time) / ``penstock.reaches``: hillsim
#: prints the step with 6 significant digits ("131 steps of 0.0190678 s"), which is up to 5e-6 off the step, so a
#: value copied from its output must pass; a step within it is taken as the grid's own step. (A step 1e-5 off the
#: Courant step would amount to a wave speed 1e-5 off, against the 5 % the grid's wave-speed adjustment allows.)
COURANT_TOLERANCE = 1e-5


@dataclass(frozen=True)
class SolverConfig:
    """Time step and the turbine-boundary (pressure-loop) solver.

    ``dt_s`` defaults to the MOC step (shortest travel time / reaches); with ``model = "moc"`` it must equal it
    within a relative 1e-5 (the step hillsim prints with 6 significant digits passes; the run takes the exact step).
    ``output_dt_s`` (optional, a whole multiple of dt) stores every n-th step only (long runs). A run whose
    steps x nodes exceed ``max_node_steps`` (default 3e10, about 100 s of loop) or whose stored series exceed
    ``max_output_mb`` (default 2000) is refused before it starts, with the estimate.
    ``tolerance`` is on the head residual as a fraction of the rated head. ``relaxation`` alpha is used by the
    traditional and improved loops (xi <- alpha D_h(xi) + (1 - alpha) xi). ``fallback`` (default true): a step the
    loop does not solve is retried with half the relaxation, then by Newton, before the run fails (false: the loop
    alone, as the paper states it). ``substeps`` (optional): sub-steps per step of the controls and the shaft
    (default: chosen from their time scales, see :mod:`simulate.loop.timestep`).
    """

    dt_s: float | None = parameter(None, unit="s", low=0.0, low_open=True, high=10.0,
                                   description="time step (default: the MOC step)")
    pressure_loop: str = parameter("improved", unit="", choices=PRESSURE_LOOPS,
                                   description="the solver of the turbine boundary")
    tolerance: float = parameter(1e-10, unit="fraction of rated head", low=0.0, low_open=True, high=1e-2,
                                 description="head residual accepted by the pressure loop")
    max_iterations: int = parameter(50, unit="1", kind="integer", low=1, high=100000,
                                    description="iterations of the pressure loop per step")
    relaxation: float = parameter(1.0, unit="1", low=0.0, low_open=True, high=1.0,
                                  description="relaxation alpha of the improved and traditional loops")
    output_dt_s: float | None = parameter(None, unit="s", low=0.0, low_open=True, high=1e4,
                                          description="interval of the stored series (a whole multiple of dt)")
    max_node_steps: float = parameter(3e10, unit="1", low=0.0, low_open=True, high=1e15,
                                      description="largest steps x nodes of a run")
    max_output_mb: float = parameter(2000.0, unit="MB", low=0.0, low_open=True, high=1e7,
                                     description="largest stored series of a run")
    fallback: bool = parameter(True, unit="", kind="boolean",
                               description="retry an unsolved step with half the relaxation, then by Newton")
    substeps: int | None = parameter(None, unit="1", kind="integer", low=1, high=10000,
                                     description="sub-steps per step of the controls and the shaft")

    def __post_init__(self):
        validate_parameters("solver", self)
        if self.tolerance < TOLERANCE_FLOOR:
            raise InputError(f"solver.tolerance = {self.tolerance!r} is below {TOLERANCE_FLOOR:.4g} (64 machine "
                             f"epsilons), the round-off floor of the head residual as a fraction of the rated head: "
                             f"no step can be solved closer, so the loop would use the floor; set solver.tolerance in "
                             f"[{TOLERANCE_FLOOR:.4g}, 0.01] (default 1e-10)")
        if self.pressure_loop == "newton" and self.relaxation != 1.0:
            raise InputError(f"solver.relaxation = {self.relaxation!r} is used by the improved and traditional "
                             f"loops; with solver.pressure_loop = \"newton\" it would be ignored: remove the key or "
                             f"choose another loop")

    def time_step_s(self, moc_dt_s: float, grid_fixes_time_step: bool, reaches: int) -> float:
        """The simulation step, s, from the MOC step ``moc_dt_s`` (shortest travel time / ``reaches``): ``dt_s``
        when given, which must meet the Courant condition (within :data:`COURANT_TOLERANCE`) where the penstock's
        grid fixes the step (``grid_fixes_time_step``), and is then the grid's own step."""
        if self.dt_s is None:
            if not (math.isfinite(moc_dt_s) and moc_dt_s > 0.0):
                raise InputError(f"the time step (shortest travel time)/penstock.reaches = {moc_dt_s!r} s is not a "
                                 f"positive number: check penstock lengths and wave speeds")
            return moc_dt_s
        if grid_fixes_time_step:
            if abs(self.dt_s - moc_dt_s) > COURANT_TOLERANCE * moc_dt_s:
                raise InputError(
                    f"solver.dt_s = {self.dt_s!r} s does not meet the MOC Courant condition: with "
                    f"penstock.reaches = {reaches} the step must be (shortest travel time)/reaches = "
                    f"{moc_dt_s!r} s (within a relative {COURANT_TOLERANCE:g}); omit solver.dt_s or change "
                    f"penstock.reaches")
            return moc_dt_s  # the grid's own step: the value hillsim prints, read back, runs the same as none
        return self.dt_s


__all__ = ["PRESSURE_LOOPS", "TOLERANCE_FLOOR", "COURANT_TOLERANCE", "SolverConfig"]
