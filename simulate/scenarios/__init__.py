"""Scenario kinds -> the schedules the time loop follows (one file per kind; the registry is
:data:`SCENARIO_CLASSES`).

``load-rejection``   governor in control; the breaker opens at ``event_time_s``: generator torque and load
                     self-regulation drop to zero (paper 004 Fig. 11b).
``closure-law``      load rejection at ``event_time_s`` with no governor: the vanes follow a prescribed linear or
                     two-stage closure (the regulating-guarantee calculation).
``frequency-steps``  no load (breaker open), speed reference steps ``speed_steps`` (cumulative, per unit) at
                     ``step_times_s`` (paper 004 Fig. 11a: +4 %, -8 %, +4 % at 10, 40, 70 s).
``load-step``        grid-connected with load self-regulation e_g; the load torque steps by ``load_step`` times the
                     initial load at ``event_time_s`` (paper 001 eq. (14)).
``opening-steps``    open loop: the vanes step by ``opening_steps`` (stroke fraction, cumulative) at ``step_times_s``;
                     the load torque stays at its initial value with self-regulation e_g (paper 000 section 5).
``short-circuit``    sub-transient generator at open circuit, rated speed and voltage; three-phase terminal fault at
                     ``event_time_s``; speed and field voltage held (the standard short-circuit test).
``field-step``       sub-transient generator at open circuit and rated speed; the field voltage steps by
                     ``field_step_pu`` at ``event_time_s`` (speed held, no voltage control).
``grid-frequency-step`` sub-transient generator on an infinite bus under its governor; the bus frequency steps by
                     ``grid_frequency_steps`` (per unit, cumulative) at ``step_times_s``.
``start-up``         the unit at standstill, vanes closed, breaker open; at ``event_time_s`` the governor opens the
                     vanes (at most to ``governor.stroke_max``) and runs the unit up to rated speed.
"""

from simulate.scenarios.base import (  # noqa: F401  (the public names of the package)
    GOVERNOR, PRESCRIBED, SCENARIO_CLASSES, SCENARIO_KEYS, SCENARIO_KINDS, ScenarioConfig, Schedules, build_schedules,
    check_steps, initial_target, steady_schedules)
from simulate.scenarios.load_rejection import LoadRejection  # noqa: F401  (each kind registers itself)
from simulate.scenarios.closure_law import ClosureLaw  # noqa: F401
from simulate.scenarios.frequency_steps import FrequencySteps  # noqa: F401
from simulate.scenarios.load_step import LoadStep  # noqa: F401
from simulate.scenarios.opening_steps import OpeningSteps  # noqa: F401
from simulate.scenarios.short_circuit import ShortCircuit  # noqa: F401
from simulate.scenarios.field_step import FieldStep  # noqa: F401
from simulate.scenarios.grid_frequency_step import GridFrequencyStep  # noqa: F401
from simulate.scenarios.start_up import StartUp  # noqa: F401

if set(SCENARIO_CLASSES) != set(SCENARIO_KINDS):
    raise ImportError(f"scenario kinds without a class: {sorted(set(SCENARIO_KINDS) - set(SCENARIO_CLASSES))}")
