"""What the nets say the linear turbine is, against what identification finds from the nonlinear transient.

:func:`compare_identification` runs the open-loop experiment on the simulator
(:mod:`simulate.identification.experiment`: opening steps of +-1 % and a seeded PRBS, then a quiet tail, sampled at
tau = 0.2 s, optionally with seeded bounded noise) and identifies:

- the six coefficients by batch least squares (paper 000 eqs. (69)-(70)) from (x, h, y, m, q), against the nets'
  analytic values (:func:`hillchart.linearize.six_coefficients`) and, for the synthetic chart, the exact turbine's;
- the ARX speed model (eq. (53)) by RLS (eqs. (57)-(59)), RLS with forgetting and dead-zone RLS (paper 001 eqs.
  (5)-(8)), against the ARX that the zero-order hold of the nets' linear plant implies (eqs. (32)-(36)); compared
  by step responses (ARX parameters are ill-conditioned) and by the simulation-mode speed error (eqs. (62)-(64));
  and, for the simulator, batch-LS ARX models of order 2-6 against the simulator's own first step;
- paper 002's (ey, e, eqh) by ARMA least squares (eqs. (9)-(12)) on the torque with the speed term removed.

:func:`identify_measured` does the identification part on a measured series (:mod:`simulate.identification.measured`).
Both return an :class:`IdentificationReport`: the numbers as a typed
:class:`~simulate.identification.results.IdentificationSummary`, the series, and the traces for the figures
(:mod:`simulate.identification.plots`); tables are :func:`simulate.identification.tables.markdown_tables`. Files are
written only by :meth:`IdentificationReport.write`.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from hillchart.errors import InputError, NumericalError
from hillchart.linearize import six_coefficients
from simulate.components.registry import PENSTOCKS
from simulate.identification.experiment import ExperimentSettings, run_experiment
from simulate.identification.results import (
    BATCH_LS_TOLERANCE,
    JUDGED_ESTIMATORS,
    SIMULATION_MODE_TOLERANCE,
    STEP_RESPONSE_TOLERANCE,
    Acceptance,
    AcceptanceCheck,
    ArmaCoefficients,
    ArmaError,
    ArmaFit,
    ArmaSkipped,
    ArxEstimate,
    ArxOrderRow,
    ArxResults,
    ArxStructure,
    CoefficientSet,
    DivergedSimulationMode,
    ExperimentOperatingPoint,
    IdentificationSummary,
    LinearParameters,
    NetsZohArx,
    ResidualRms,
    SeriesIdentification,
    SimulatedStepComparison,
    SimulationInfo,
    SimulationModeError,
    SixCoefficientResult,
    to_json_dict,
)
from simulate.identification.estimators import (
    ArmaLeastSquares,
    DeadZoneRLS,
    RecursiveLeastSquares,
    SixCoefficientLeastSquares,
    arx_regressors,
    arx_start,
    simulation_mode_output,
)
from simulate.linear.models import ArxModel, LinearPlant, combined_coefficient
from simulate.identification.linear_reference import linear_reference
from simulate.identification.measured import RelativeSeries


@dataclass(frozen=True, eq=False)
class StepResponses:
    """Compared speed step responses per unit opening step, each with the shape of ``time_s`` (s): the ZOH of the
    nets' linear plant, the identified ARX models (``estimates[name]``) and the simulator's own first step (NaN
    beyond its hold)."""

    time_s: np.ndarray
    nets_zoh: np.ndarray | None = None
    estimates: dict = field(default_factory=dict)
    simulated_first_step: np.ndarray | None = None

    def curves(self) -> dict:
        """``{label: response}`` in plotting order: ``nets_zoh``, the estimators, ``simulated_first_step``."""
        out = {} if self.nets_zoh is None else {"nets_zoh": self.nets_zoh}
        out.update(self.estimates)
        if self.simulated_first_step is not None:
            out["simulated_first_step"] = self.simulated_first_step
        return out


@dataclass(frozen=True, eq=False)
class SimulationModeTraces:
    """Simulation-mode outputs x_hat (final theta) per estimator; the model output starts at sample ``start``."""

    start: int
    x_hat: dict


@dataclass(frozen=True, eq=False)
class IdentificationTraces:
    """The arrays behind the figures: ``histories[estimator]`` = theta(k) (N, p), the step responses and the
    simulation-mode outputs."""

    histories: dict
    step_responses: StepResponses
    simulation_mode: SimulationModeTraces


@dataclass(frozen=True, eq=False)
class IdentificationReport:
    """Everything :func:`compare_identification` / :func:`identify_measured` found.

    Attributes
    ----------
    summary : IdentificationSummary
        The numbers (``summary.acceptance`` holds the issue's checks when a nets reference is available).
    series : RelativeSeries
        The (noisy) identification data.
    traces : IdentificationTraces
        theta(k) histories, step responses and simulation-mode outputs for the figures.
    simulation : object or None
        The :class:`~simulate.results.result.SimulationResult` of the nonlinear run (None for measured data).
    """

    summary: IdentificationSummary
    series: RelativeSeries
    traces: IdentificationTraces
    simulation: object = None

    def to_dict(self) -> dict:
        """The summary as JSON-ready data (the content of ``identification.json``)."""
        return to_json_dict(self.summary)

    def write(self, out_dir, *, plot: bool = True) -> dict[str, Path]:
        """Write ``identification.json``, ``identified_series.csv`` and (``plot``) the figures into ``out_dir``;
        returns the paths."""
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        paths = {"json": out / "identification.json", "series": out / "identified_series.csv"}
        paths["json"].write_text(json.dumps(self.to_dict(), indent=2) + "\n", encoding="utf-8")
        s = self.series
        np.savetxt(paths["series"], np.column_stack([s.time_s, s.x, s.h, s.y, s.m, s.q]), delimiter=",",
                   header="time_s,x,h,y,m,q", comments="", fmt="%.12g")
        if plot:
            from simulate.identification.plots import plot_report

            paths.update(plot_report(self, out))
        return paths


# ----------------------------------------------------------------------------------------------------------------
# estimators on one series
# ----------------------------------------------------------------------------------------------------------------


def arx_structure(kind: str, order: int) -> ArxStructure:
    """``"zoh"``: n_a = n_b = order, no delay (the exact zero-order hold); ``"paper"``: eq. (53) as printed."""
    if kind == "zoh":
        return ArxStructure(n_a=order, n_b=order, input_delay=0)
    return ArxStructure(n_a=3, n_b=2, input_delay=1)  # paper 000 eq. (53) as printed


def _step_error(model: ArxModel, reference: ArxModel, n_samples: int) -> float:
    s_model = model.step_response(n_samples)
    s_ref = reference.step_response(n_samples)
    return float(np.max(np.abs(s_model - s_ref)) / np.max(np.abs(s_ref)))


def _six_coefficients(series: RelativeSeries, reference_coefficients, exact_coefficients) -> SixCoefficientResult:
    """Batch least squares of the six coefficients (paper 000 eqs. 69-70) against the nets and the exact turbine."""
    batch = SixCoefficientLeastSquares().fit(np.column_stack([series.x, series.h, series.y]),
                                             np.column_stack([series.m, series.q]))
    batch_ls = CoefficientSet(**batch.six_coefficients_)
    nets = CoefficientSet.of(reference_coefficients) if reference_coefficients is not None else None
    exact = CoefficientSet.of(exact_coefficients) if exact_coefficients is not None else None
    return SixCoefficientResult(
        batch_ls=batch_ls, condition_number=batch.condition_number_,
        residual_rms=ResidualRms(m=float(batch.residual_rms_[0]), q=float(batch.residual_rms_[1])),
        nets=nets,
        batch_ls_minus_nets=batch_ls.minus(nets) if nets is not None else None,
        max_abs_batch_ls_minus_nets=batch_ls.max_abs_difference(nets) if nets is not None else None,
        exact=exact,
        max_abs_nets_minus_exact=nets.max_abs_difference(exact) if nets is not None and exact is not None else None,
        max_abs_batch_ls_minus_exact=batch_ls.max_abs_difference(exact) if exact is not None else None)


def _arma(series: RelativeSeries, arma_series, reference: LinearPlant, reference_coefficients, ex_batch_ls: float):
    """Paper 002 ARMA on the torque at constant speed (speed term removed with the batch-LS ex)."""
    # paper 002 assumes rigid water hammer (its eq. (2)); with an elastic penstock the first-order model misfits
    if reference.elastic:
        return ArmaSkipped(skipped="the ARMA model of Wei et al. (2016) assumes rigid water hammer; "
                                    "run with the rigid model")
    sa = arma_series if arma_series is not None else series
    m_const_speed = sa.m - ex_batch_ls * sa.x
    try:
        arma = ArmaLeastSquares(water_time_s=reference.water_time_s, sample_time_s=sa.sample_time_s).fit(
            sa.y, m_const_speed)
    except (InputError, NumericalError) as exc:  # e.g. a = -1 or rank-deficient: recorded, the rest stands
        return ArmaError(error=str(exc))
    nets = with_friction = None
    if reference_coefficients is not None:
        nets = ArmaCoefficients(ey=reference_coefficients.ey, e=combined_coefficient(reference_coefficients),
                                eqh=reference_coefficients.eqh)
        eff = reference.effective_coefficients()  # the penstock friction seen by the torque
        with_friction = ArmaCoefficients(ey=eff[1], e=combined_coefficient(eff), eqh=eff[5])
    return ArmaFit(a=arma.a_, b=arma.b_, c=arma.c_, ey=arma.ey_, e=arma.e_, eqh=arma.eqh_,
                   water_time_s=reference.water_time_s, sample_time_s=sa.sample_time_s,
                   note="m - ex_LS x used as the constant-speed torque (eqx x neglected)",
                   nets=nets, nets_with_friction=with_friction)


def coefficients_unjudged(plant) -> str | None:
    """Why the nets' six coefficients are not the linear model of ``plant``, or None when they are: a
    double-regulated unit whose blades follow the cam through their servo has a lag the six coefficients on the cam
    leave out: they hold for blades on the cam (a test identifies the shipped bulb plant close to them with a fast
    servo, far from them with its own)."""
    servo = getattr(plant, "blade_servo", None)
    if servo is None or servo.mode != "combinator":
        return None
    return (f"the blades follow the cam through their servo (blade_servo.servo_time_s = {servo.servo_time_s:g} s), a "
            f"lag the nets' six coefficients on the cam leave out")


def identify_series(series: RelativeSeries, settings: ExperimentSettings, *, reference: LinearPlant | None = None,
                    reference_coefficients=None, exact_coefficients=None, model_order: int | None = None,
                    arma_series: RelativeSeries | None = None, penstock_matches: bool = True,
                    unjudged_reason: str | None = None) -> tuple[SeriesIdentification, IdentificationTraces]:
    """Run every estimator on ``series`` and compare with the nets' linear plant when given.

    ``penstock_matches``: the data come from the penstock model the linear plant is (rigid, lumped), so the step
    responses are judged; ``unjudged_reason``: why the plant behind the data is not the six coefficients'
    (:func:`coefficients_unjudged`), so batch LS and the step responses are reported against them, not judged.

    Returns the numbers (:class:`~simulate.identification.results.SeriesIdentification`) and the traces for the
    figures.
    """
    tau = series.sample_time_s
    order = model_order if model_order is not None else (reference.state_space().A.shape[0] if reference else 3)
    main = arx_structure(settings.arx_structure, order)
    other = arx_structure("paper" if settings.arx_structure == "zoh" else "zoh", order)
    x, u = series.x, series.y

    six = _six_coefficients(series, reference_coefficients, exact_coefficients)

    # --- ARX by recursive estimators ------------------------------------------------------------------------------
    nets_arx = reference.arx(tau) if reference is not None else None
    eps0 = settings.dead_zone_eps0
    if eps0 is None:
        a_sum = float(np.abs(nets_arx.a).sum()) if nets_arx is not None else 3.0
        eps0 = (1.0 + a_sum) * settings.noise_level if settings.noise_level > 0 else 1e-7
    estimators = {
        "rls": lambda: RecursiveLeastSquares(p0=settings.rls_p0),
        "rls_forgetting": lambda: RecursiveLeastSquares(p0=settings.rls_p0,
                                                        forgetting_factor=settings.forgetting_factor),
        "dead_zone_rls": lambda: DeadZoneRLS(eps0=eps0, delta=settings.dead_zone_delta, p0=settings.rls_p0),
    }
    estimates: dict[str, ArxEstimate] = {}
    histories: dict = {}
    x_hat: dict = {}
    k0 = 0
    horizon_s = 60.0
    if reference is not None:
        slow = min(abs(np.real(reference.state_space().eigenvalues())))
        horizon_s = 6.0 / slow  # six slowest time constants: the step has settled to 0.25 %
    n_step = max(10, int(round(horizon_s / tau)))
    step_time_s = tau * np.arange(n_step + 1)
    curves: dict = {}
    for label, structure in (("", main), ("paper_eq53_", other) if settings.arx_structure == "zoh"
                             else ("zoh_", other)):
        shape = {"n_a": structure.n_a, "n_b": structure.n_b, "input_delay": structure.input_delay}
        phi, target = arx_regressors(x, u, **shape)
        for name, make in estimators.items():
            if label and name != "rls":
                continue  # the alternative structure: plain RLS only
            est = make().fit(phi, target)
            model = ArxModel.from_theta(est.theta_, **shape, sample_time_s=tau)
            final = simulation_mode_output(est.theta_, x, u, **shape)
            try:
                online = SimulationModeError.of(simulation_mode_output(est.theta_prior_, x, u, **shape))
            except NumericalError as exc:  # an on-line model that diverges is a result: recorded
                online = DivergedSimulationMode(error=str(exc))
            tail = est.theta_history_[-int(min(len(est.theta_history_), round(settings.quiet_s / tau) or 1)):]
            step_error = None
            if nets_arx is not None:
                step_error = _step_error(model, nets_arx, n_step)
                curves[label + name] = model.step_response(n_step)
            if not label:
                histories[name] = est.theta_history_
                x_hat[name] = final.x_hat
                k0 = arx_start(structure.n_a, structure.n_b, structure.input_delay)
            estimates[label + name] = ArxEstimate(
                theta=tuple(est.theta_.tolist()), updates=int(est.n_updates_), **shape,
                simulation_mode_final_theta=SimulationModeError.of(final), simulation_mode_online=online,
                theta_spread_quiet_tail=float(np.max(np.linalg.norm(tail - tail[0], axis=1))),
                step_error_vs_nets=step_error)
    arx = ArxResults(dead_zone_eps0=eps0, forgetting_factor=settings.forgetting_factor, rls_p0=settings.rls_p0,
                     nets_zoh=NetsZohArx.of(nets_arx) if nets_arx is not None else None, **estimates)

    arma = None
    if reference is not None:
        arma = _arma(series, arma_series, reference, reference_coefficients, six.batch_ls.ex)

    acceptance = note = None
    if reference is not None:
        batch_error = six.max_abs_batch_ls_minus_nets if six.max_abs_batch_ls_minus_nets is not None else np.inf
        judged = {"batch_ls": AcceptanceCheck(name="batch_ls_within_0.02_of_nets", value=batch_error,
                                              bound=BATCH_LS_TOLERANCE,
                                              passed=None if unjudged_reason else
                                              bool(batch_error <= BATCH_LS_TOLERANCE),
                                              reason=unjudged_reason or "")}
        for name in JUDGED_ESTIMATORS:
            estimate = getattr(arx, name)
            # the 5 % step bound applies when the data come from the penstock model the linear model is (rigid /
            # lumped); for moc / zdomain the step error is reported, not judged
            judged[f"{name}_step_response"] = AcceptanceCheck(
                name=f"{name}_step_response_within_5pct", value=estimate.step_error_vs_nets,
                bound=STEP_RESPONSE_TOLERANCE,
                passed=(bool(estimate.step_error_vs_nets <= STEP_RESPONSE_TOLERANCE)
                        if penstock_matches and not unjudged_reason else None),
                reason=("penstock model is not the linear one" if not penstock_matches else
                        unjudged_reason or ""))
            sim = estimate.simulation_mode_final_theta
            relative = getattr(sim, "relative_error", np.inf)  # a diverged simulation mode fails
            judged[f"{name}_simulation_mode"] = AcceptanceCheck(
                name=f"{name}_simulation_mode_within_5pct_of_peak", value=relative, bound=SIMULATION_MODE_TOLERANCE,
                passed=bool(relative <= SIMULATION_MODE_TOLERANCE))
        acceptance = Acceptance(**judged)
    found = SeriesIdentification(sample_time_s=tau, samples=int(x.size), arx_structure=main,
                                 peak_abs_x=float(np.max(np.abs(x))), six_coefficients=six, arx=arx,
                                 step_response_horizon_s=float(n_step * tau), arma_paper002=arma,
                                 acceptance=acceptance, acceptance_note=note)
    nets_step = nets_arx.step_response(n_step) if nets_arx is not None else None
    steps = StepResponses(time_s=step_time_s, nets_zoh=nets_step, estimates=curves)
    traces = IdentificationTraces(histories=histories, step_responses=steps,
                                  simulation_mode=SimulationModeTraces(start=k0, x_hat=x_hat))
    return found, traces


# ----------------------------------------------------------------------------------------------------------------
# the whole comparison on the simulator
# ----------------------------------------------------------------------------------------------------------------


def _simulated_first_step(clean: RelativeSeries, settings: ExperimentSettings, linear: LinearPlant, n_samples: int):
    """The simulator's own first opening step (noise-free, per unit step) against the nets' linear prediction:
    ``(comparison, step)`` with the step padded with NaN (or cut) to ``n_samples``."""
    times, levels = settings.opening_schedule()
    k_step = int(round(times[0] / settings.sample_time_s))
    n_hold = int(round((times[1] - times[0]) / settings.sample_time_s))
    simulated = clean.x[k_step: k_step + n_hold + 1] / levels[0]
    predicted = linear.step_response(settings.sample_time_s, n_hold)[:, 0]
    comparison = SimulatedStepComparison(
        max_error_frac_of_peak=float(np.max(np.abs(simulated - predicted)) / np.max(np.abs(predicted))),
        final_value_simulated=float(simulated[-1]), final_value_nets=float(predicted[-1]),
        duration_s=float(n_hold * settings.sample_time_s))
    step = np.r_[simulated, np.full(max(0, n_samples - simulated.size), np.nan)][:n_samples]
    return comparison, step


def arx_order_sweep(series: RelativeSeries, nets_step: np.ndarray, simulated_step: np.ndarray,
                    orders=range(2, 7)) -> tuple[ArxOrderRow, ...]:
    """Batch-LS ARX (lstsq, ZOH structure) per order, step response against the nets' ZOH model and against the
    simulator's own first step (the lumped/rigid models are order 3/2; MOC has more modes)."""
    ok = np.isfinite(simulated_step)
    rows = []
    for order in orders:
        phi, target = arx_regressors(series.x, series.y, n_a=order, n_b=order, input_delay=0)
        theta = np.linalg.lstsq(phi, target, rcond=None)[0]
        step = ArxModel.from_theta(theta, n_a=order, n_b=order).step_response(nets_step.size - 1)
        if not np.all(np.isfinite(step)) or np.max(np.abs(step)) > 1e6:
            rows.append(ArxOrderRow(order=order, unstable=True, step_error_vs_nets=None,
                                    step_error_vs_simulated_step=None))
            continue
        rows.append(ArxOrderRow(
            order=order, unstable=False,
            step_error_vs_nets=float(np.max(np.abs(step - nets_step)) / np.max(np.abs(nets_step))),
            step_error_vs_simulated_step=float(np.max(np.abs(step[ok] - simulated_step[ok]))
                                               / np.max(np.abs(simulated_step[ok])))))
    return tuple(rows)


def compare_identification(plant, *, settings: ExperimentSettings | None = None, characteristics=None,
                           exact=None, penstock_model: str | None = None,
                           initial_opening: float | None = None) -> IdentificationReport:
    """Simulate the identification experiment on ``plant`` and compare identification with the nets.

    Parameters
    ----------
    plant : simulate.config.PlantConfig
        Its scenario's initial power or opening sets the operating point (frequency-steps: no-load is refused).
    settings : ExperimentSettings, optional
    characteristics : Characteristics, optional
        Overrides the plant's nets (as in :func:`simulate.loop.engine.run_simulation`).
    exact : Characteristics, optional
        The exact turbine behind a synthetic chart (e.g. :class:`hillchart.synthetic.francis.SyntheticFrancis`): its six
        coefficients are reported next to the nets' and the batch-LS ones.
    penstock_model : str, optional
        Override the plant's penstock model (``rigid`` / ``lumped`` match the linear models exactly; ``moc`` and
        ``zdomain`` are compared against the lumped elastic model).
    initial_opening : float, optional
        Operating point as a stroke fraction (default: the plant scenario's initial power or opening).

    Returns
    -------
    IdentificationReport
    """
    from simulate.components.turbine.component import characteristics_of

    settings = settings or ExperimentSettings()
    chars = characteristics_of(plant, characteristics)
    run = run_experiment(plant, settings, chars, penstock_model=penstock_model, initial_opening=initial_opening)
    run_plant, steady, result = run.plant, run.steady, run.result
    coeffs, linear = linear_reference(run_plant, chars, steady)
    exact_coeffs = six_coefficients(exact, n11=coeffs.n11_rpm, opening=coeffs.opening) if exact is not None else None
    found, traces = identify_series(run.series, settings, reference=linear, reference_coefficients=coeffs,
                                    exact_coefficients=exact_coeffs, arma_series=run.arma_series,
                                    penstock_matches=PENSTOCKS.traits(run_plant.penstock.model).lumped_column,
                                    unjudged_reason=coefficients_unjudged(run_plant))
    simulated_step = sweep = None
    if settings.step_amplitude > 0:
        steps = traces.step_responses
        simulated_step, first_step = _simulated_first_step(run.clean, settings, linear, steps.time_s.size)
        sweep = arx_order_sweep(run.series, steps.nets_zoh, first_step)
        traces = replace(traces, step_responses=replace(steps, simulated_first_step=first_step))
    summary = IdentificationSummary.build(
        found,
        source="simulation",
        penstock_model=run_plant.penstock.model,
        linear_model="elastic (lumped, eqs. 24-30)" if linear.elastic else "inelastic (rigid, eqs. 10-12)",
        operating_point=ExperimentOperatingPoint(
            speed_rpm=steady.speed_rpm, head_m=steady.head_m, flow_m3_s=steady.flow_m3_s, torque_nm=steady.torque_nm,
            stroke=steady.stroke, opening_chart=steady.opening_chart, n11_rpm=coeffs.n11_rpm,
            q11_m3_s=coeffs.q11_m3_s, m11_nm=coeffs.m11_nm),
        linear_parameters=LinearParameters(
            water_time_s=linear.water_time_s, inertia_time_s=linear.inertia_time_s,
            self_regulation=linear.self_regulation, wave_time_s=linear.wave_time_s, alpha=linear.alpha,
            friction_slope=linear.friction_slope,
            eigenvalues=tuple(complex(v) for v in linear.state_space().eigenvalues())),
        experiment=settings,
        simulation=SimulationInfo(dt_s=float(result.meta["dt_s"]), t_end_s=float(result.time_s[-1]),
                                  wall_time_s=float(result.wall_time_s),
                                  mean_iterations=float(np.mean(result.iterations[1:]))),
        simulated_step_vs_nets=simulated_step,
        arx_order_sweep=sweep,
    )
    return IdentificationReport(summary=summary, series=run.series, traces=traces, simulation=result)


def identify_measured(series: RelativeSeries, settings: ExperimentSettings, *, plant=None, characteristics=None,
                      exact=None, arma_series: RelativeSeries | None = None) -> IdentificationReport:
    """Identification on a measured series; with ``plant`` the nets' linear model at the series' operating point
    is the reference (the opening column must then be the stroke fraction)."""
    reference = coeffs = exact_coeffs = None
    if plant is not None:
        from types import SimpleNamespace

        from simulate.components.turbine.component import characteristics_of

        chars = characteristics_of(plant, characteristics)
        op = series.operating_point
        steady = SimpleNamespace(speed_rpm=op.speed_rpm, head_m=op.head_m, flow_m3_s=op.flow_m3_s,
                                 torque_nm=op.torque_nm, opening_chart=op.opening * plant.turbine.opening_max)
        coeffs, reference = linear_reference(plant, chars, steady)
        if exact is not None:
            exact_coeffs = six_coefficients(exact, n11=coeffs.n11_rpm, opening=coeffs.opening)
    found, traces = identify_series(series, settings, reference=reference, reference_coefficients=coeffs,
                                    exact_coefficients=exact_coeffs, arma_series=arma_series,
                                    penstock_matches=(plant is not None
                                                      and PENSTOCKS.traits(plant.penstock.model).lumped_column),
                                    unjudged_reason=coefficients_unjudged(plant) if plant is not None else None)
    summary = IdentificationSummary.build(
        found, source="measured", penstock_model=plant.penstock.model if plant is not None else None,
        operating_point=series.operating_point, experiment=settings)
    return IdentificationReport(summary=summary, series=series, traces=traces)
