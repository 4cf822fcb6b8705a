"""The open-loop identification experiment on the simulator: its settings, the plant it runs on, and the run.

:class:`ExperimentSettings` describes the experiment (opening steps of +-1 % and a seeded PRBS, then a quiet tail,
sampled at tau = 0.2 s as in paper 000 section 5); :func:`experiment_plant` puts its opening schedule into a plant
(scenario ``opening-steps``, governor off); :func:`run_experiment` simulates it around the plant's verified operating
point and returns the relative series (:class:`simulate.identification.measured.RelativeSeries`) the estimators see
(:mod:`simulate.identification.compare`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from hillchart.errors import InputError
from simulate.components.registry import PENSTOCKS
from simulate.identification.measured import OperatingPoint, RelativeSeries

@dataclass(frozen=True)
class ExperimentSettings:
    """The identification experiment (all times in s; amplitudes are relative openings y = da/a0).

    Attributes
    ----------
    sample_time_s : float
        tau, the sampling of the identification data (Wang et al. 2023: 0.2 s).
    step_amplitude : float
        Size of the opening steps: +A at ``lead_s``, back, -A, back, each held ``step_hold_s``.
    step_hold_s : float
    prbs_amplitude : float
        PRBS level +-A after the steps, bits of ``prbs_bit_s`` for ``prbs_duration_s`` (seeded).
    prbs_bit_s : float
    prbs_duration_s : float
    quiet_s : float
        Constant opening after the PRBS (where noise alone drives the estimators: drift shows here).
    lead_s : float
        Steady operation before the first step.
    noise_level : float
        Half-width of uniform measurement noise added to x, h, m, q (relative units); 0 = noise-free.
    seed : int
        Seed of the PRBS and of the noise.
    rls_p0 : float
        P(0) = rls_p0 I for every recursive estimator (1 is the paper's; per-unit increments of 1 % need ~1e6,
        see :class:`simulate.identification.estimators.RecursiveLeastSquares`).
    forgetting_factor : float
        lambda of the "RLS with forgetting" estimator (the plain RLS uses 1).
    dead_zone_eps0 : float or None
        Dead zone on the a-priori residual; None: 2 (1 + sum |a_i|) noise_level (the equation-error bound, doubled),
        or 1e-7 without noise.
    dead_zone_delta : float
        delta of eq. (8) of Wang, Ahmed et al..
    arx_structure : str
        ``"zoh"`` (n_a = n_b = model order, no delay: the exact zero-order hold) or ``"paper"`` (eq. (53) as printed:
        n_a = 3, n_b = 2, one sample delay). The other one is always reported too.
    arma_sample_time_s : float
        Sampling of the ARMA fit of Wei et al. 2016 (its eq. (6) is a backward difference, biased by about
        Dt / (2 eqh Tw): 0.04 s keeps that near 2 % where tau = 0.2 s would give ~15 %).
    """

    sample_time_s: float = 0.2
    step_amplitude: float = 0.01
    step_hold_s: float = 40.0
    prbs_amplitude: float = 0.01
    prbs_bit_s: float = 1.0
    prbs_duration_s: float = 160.0
    quiet_s: float = 100.0
    lead_s: float = 2.0
    noise_level: float = 0.0
    seed: int = 0
    rls_p0: float = 1e10
    forgetting_factor: float = 0.98
    dead_zone_eps0: float | None = None
    dead_zone_delta: float = 0.01
    arx_structure: str = "zoh"
    arma_sample_time_s: float = 0.04

    def __post_init__(self):
        def check(name, low, high, *, low_open=True, allow_none=False):
            value = getattr(self, name)
            if allow_none and value is None:
                return
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or (
                    value <= low if low_open else value < low) or value > high:
                bracket = "(" if low_open else "["
                raise InputError(f"experiment.{name} must be a number in {bracket}{low}, {high}], got {value!r}")

        check("sample_time_s", 0.0, 10.0)
        check("step_amplitude", 0.0, 0.2, low_open=False)
        check("step_hold_s", 0.0, 1e4)
        check("prbs_amplitude", 0.0, 0.2, low_open=False)
        check("prbs_bit_s", 0.0, 1e3)
        check("prbs_duration_s", 0.0, 1e5, low_open=False)
        check("quiet_s", 0.0, 1e5, low_open=False)
        check("lead_s", 0.0, 1e3, low_open=False)
        check("noise_level", 0.0, 0.1, low_open=False)
        check("rls_p0", 0.0, 1e15)
        check("forgetting_factor", 0.0, 1.0)
        check("dead_zone_eps0", 0.0, 1.0, low_open=False, allow_none=True)
        check("dead_zone_delta", 0.0, 1e3)
        check("arma_sample_time_s", 0.0, 10.0)
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise InputError(f"experiment.seed must be an integer >= 0, got {self.seed!r}")
        if self.arx_structure not in ("zoh", "paper"):
            raise InputError(f"experiment.arx_structure must be 'zoh' or 'paper', got {self.arx_structure!r}")
        if self.step_amplitude == 0 and (self.prbs_amplitude == 0 or self.prbs_duration_s == 0):
            raise InputError("experiment: step_amplitude and prbs_amplitude/prbs_duration_s are all 0: no excitation")
        if self.prbs_bit_s < self.sample_time_s - 1e-12:
            raise InputError(f"experiment.prbs_bit_s must be >= sample_time_s ({self.sample_time_s}), "
                             f"got {self.prbs_bit_s!r}")
        # the same memory bound as a measured series (simulate.identification.series_checks): samples x bytes per sample
        from simulate.identification.series_checks import BYTES_PER_SAMPLE, MAX_BYTES

        samples = self.duration_s / self.sample_time_s + 1
        if samples * BYTES_PER_SAMPLE > MAX_BYTES:
            raise InputError(f"experiment.sample_time_s = {self.sample_time_s:g} s over the {self.duration_s:g} s "
                             f"experiment is {samples:.3g} samples, about {samples * BYTES_PER_SAMPLE / 1024**3:.3g} "
                             f"GiB to identify (limit {MAX_BYTES / 1024**3:.3g} GiB); give a larger --tau (the "
                             f"default 0.2 s suits a hydro unit) or a shorter experiment")

    @property
    def duration_s(self) -> float:
        return self.lead_s + 4 * self.step_hold_s + self.prbs_duration_s + self.quiet_s

    def opening_schedule(self) -> tuple[np.ndarray, np.ndarray]:
        """``(times_s, levels)``: relative opening y switches to ``levels[i]`` at ``times_s[i]`` (0 before).

        All switching times are multiples of ``sample_time_s``, so the sampled opening is exactly piecewise
        constant between samples (the zero-order hold the ARX model assumes).

        Examples
        --------
        >>> times, levels = ExperimentSettings(step_hold_s=10.0, prbs_duration_s=0.0).opening_schedule()
        >>> times.tolist(), levels.tolist()
        ([2.0, 12.0, 22.0, 32.0], [0.01, 0.0, -0.01, 0.0])
        """
        tau = self.sample_time_s

        def snap(t):
            return round(t / tau) * tau

        a = self.step_amplitude
        t0 = snap(self.lead_s)
        hold = snap(self.step_hold_s)
        times = [t0, t0 + hold, t0 + 2 * hold, t0 + 3 * hold]
        levels = [a, 0.0, -a, 0.0]
        start = t0 + 4 * hold
        if self.prbs_amplitude > 0 and self.prbs_duration_s > 0:
            rng = np.random.default_rng(self.seed)
            bit = max(1, round(self.prbs_bit_s / tau)) * tau
            n_bits = int(self.prbs_duration_s // bit)
            bits = rng.choice([-1.0, 1.0], size=n_bits) * self.prbs_amplitude
            for i, value in enumerate(bits):
                times.append(start + i * bit)
                levels.append(float(value))
            times.append(start + n_bits * bit)
            levels.append(0.0)
        times, levels = np.array(times), np.array(levels)
        keep = np.r_[True, np.diff(levels) != 0]  # drop repeated levels
        return times[keep], levels[keep]


def experiment_plant(plant, settings: ExperimentSettings, *, initial_stroke: float, penstock_model: str | None = None):
    """The plant with the open-loop identification scenario (kind ``opening-steps``) and, for rigid/lumped, a
    time step that divides tau (so the opening switches land on the samples)."""
    from simulate.config import ScenarioConfig

    times, levels = settings.opening_schedule()
    increments = np.diff(np.r_[0.0, levels]) * initial_stroke  # cumulative stroke steps (y is relative to a0)
    pen = plant.penstock if penstock_model is None else replace(plant.penstock, model=penstock_model)
    solver = plant.solver
    tau = settings.sample_time_s
    if not PENSTOCKS.traits(pen.model).grid_fixes_time_step:
        dt0 = pen.moc_time_step_s if solver.dt_s is None else solver.dt_s
        solver = replace(solver, dt_s=tau / max(1, math.ceil(tau / dt0 - 1e-9)))
    else:
        # the MOC step is fixed by the Courant condition: move each switch back onto the simulation grid (at most
        # one step early) so that the sample at k tau sees the new opening, not an interpolated half step
        dt = replace(plant, penstock=pen, solver=solver).time_step_s
        times = np.floor(times / dt + 1e-6) * dt
    scenario = ScenarioConfig(kind="opening-steps", t_end_s=settings.duration_s, initial_opening=initial_stroke,
                              opening_steps=tuple(float(v) for v in increments),
                              step_times_s=tuple(float(t) for t in times))
    return replace(plant, penstock=pen, solver=solver, scenario=scenario)


@dataclass(frozen=True, eq=False)
class ExperimentRun:
    """The simulated experiment: the plant it ran on, its verified steady state, the simulator's result and the
    relative series sampled at tau (noise-free and with the settings' noise) and at the ARMA sampling (noisy)."""

    plant: object  # simulate.config.PlantConfig with the experiment's scenario
    steady: object  # simulate.loop.steady.SteadyState of that plant
    result: object  # simulate.results.result.SimulationResult
    operating_point: OperatingPoint
    clean: RelativeSeries
    series: RelativeSeries
    arma_series: RelativeSeries


def experiment_stroke(plant, characteristics, initial_opening: float | None = None) -> float:
    """The operating stroke of the experiment: ``initial_opening`` (checked against the governor's stroke range) or
    the stroke of the plant scenario's verified initial state (a frequency-steps scenario has no load: refused)."""
    from simulate.loop.engine import initial_state

    if initial_opening is not None:
        gov = plant.governor
        if isinstance(initial_opening, bool) or not isinstance(initial_opening, (int, float)) or not (
                gov.stroke_min < initial_opening <= gov.stroke_max):
            raise InputError(f"initial_opening must be a stroke fraction in (governor.stroke_min, "
                             f"governor.stroke_max] = ({gov.stroke_min}, {gov.stroke_max}], got {initial_opening!r}")
        return float(initial_opening)
    if plant.scenario.kind == "frequency-steps":
        raise InputError("identification needs a loaded operating point: the plant's scenario is frequency-steps "
                         "(no load); give initial_opening or use a scenario with initial_power_mw")
    return initial_state(plant, characteristics).stroke


def run_experiment(plant, settings: ExperimentSettings, characteristics, *, penstock_model: str | None = None,
                   initial_opening: float | None = None) -> ExperimentRun:
    """Simulate the experiment of ``settings`` on ``plant`` (see :func:`experiment_plant`) and sample it.

    The noise of the tau series is seeded with ``settings.seed + 1``, that of the ARMA series with ``seed + 2``.
    """
    from simulate.loop.engine import initial_state, run_simulation

    stroke0 = experiment_stroke(plant, characteristics, initial_opening)
    run_plant = experiment_plant(plant, settings, initial_stroke=stroke0, penstock_model=penstock_model)
    result = run_simulation(run_plant, characteristics)
    steady = initial_state(run_plant, characteristics)
    op = OperatingPoint(speed_rpm=steady.speed_rpm, head_m=steady.head_m, flow_m3_s=steady.flow_m3_s,
                        torque_nm=steady.torque_nm, opening=steady.stroke)
    clean = RelativeSeries.from_physical(result.time_s, result.speed_rpm, result.head_m, result.opening,
                                         result.torque_nm, result.flow_m3_s, sample_time_s=settings.sample_time_s,
                                         operating_point=op)
    series = clean.with_noise(settings.noise_level, settings.seed + 1)
    arma_series = RelativeSeries.from_physical(
        result.time_s, result.speed_rpm, result.head_m, result.opening, result.torque_nm, result.flow_m3_s,
        sample_time_s=settings.arma_sample_time_s, operating_point=op).with_noise(settings.noise_level,
                                                                                 settings.seed + 2)
    return ExperimentRun(plant=run_plant, steady=steady, result=result, operating_point=op, clean=clean,
                         series=series, arma_series=arma_series)
