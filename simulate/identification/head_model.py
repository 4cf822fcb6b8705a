"""Water-head model and flow/head estimates of paper 000 (eqs. (60)-(61), (65)-(68)); closed-loop identification.

Head ARX (eqs. (60)-(61)), learned by the RLS of eqs. (57)-(59) beside the speed model::

    h(k+1) = a_h h(k) + b_h h(k-1) - c_h Tw dq/dt(k-1)          eq. (60) as printed, theta_h = [a_h, b_h, c_h]

Two regressor structures (:func:`head_regressors`):

``"paper"``     ``[h(k), h(k-1), -Tw (q(k) - q(k-1))/tau]``: eq. (60) with dq/dt(k-1) as the difference over
                [k-1, k] (the printed form gives no difference formula; the backward one over [k-2, k-1] fits worse).
``"interval"``  ``[h(k), .., h(k-n_a+1), v(k), .., v(k-n_b+1), q(k+1)]`` with ``v(j) = -Tw (q(j+1) - q(j))/tau``,
                the mean of -Tw dq/dt over [j tau, (j+1) tau]. For the lumped penstock alpha Te^2 h'' + h = -Tw q'
                (eq. (16)) and a flow that is linear between samples this is the exact discretization with n_a = n_b
                = 2; q(k+1) carries the steady friction loss h = h_w - r_f q (an extension, as in
                :mod:`simulate.linear.models`). The printed structure lacks v(k), the water hammer of the current
                interval, which is why it lags every opening step (measured in the README). Default.

Estimates in simulation mode (own past outputs fed back, measured inputs; eqs. (62)-(63) and (65)):

* speed x_hat from the speed ARX (eqs. (62)-(63)),
* head h_hat from the head ARX with measured flow (eq. (65); eq. (67)-(68) are its printed values),
* flow q_hat = eqx x_hat + eqy y + eqh h_hat (eq. (5) with the batch-LS coefficients of eq. (70)).

Errors are reported as fractions of the largest deviation of the measured signal (``max|s - s_hat| / max|s|``).
The runs come from the public simulator API (:func:`simulate.loop.engine.run_simulation`).

Closed loop (:func:`closed_loop_identification`): the governor PI (paper tests 5-6: Kp 7.5 with TI 0.5 s and
0.15 s, relative units) in the loop; the ARX is fitted directly on (x, y). See the function for when that works.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from hillchart.errors import InputError, NumericalError
from simulate.identification.estimators import (RecursiveLeastSquares, SixCoefficientLeastSquares, arx_regressors,
                                               simulation_mode_output)
from simulate.linear.models import ArxModel

HEAD_STRUCTURES = ("interval", "paper")


def _fraction(error: np.ndarray, signal: np.ndarray) -> float:
    peak = float(np.max(np.abs(signal)))
    return float(np.max(np.abs(error)) / peak) if peak > 0 else float("nan")


def head_regressors(h, q, *, water_time_s: float, sample_time_s: float, structure: str = "interval",
                    n_a: int = 2, n_b: int = 2):
    """Rows phi_h(k) and targets h(k+1) of the head ARX (module docstring), for every k with all samples.

    Returns
    -------
    phi : ndarray (n_rows, p), target : ndarray (n_rows,), ks : ndarray (n_rows,) of the k of each row.

    Examples
    --------
    >>> phi, target, ks = head_regressors([0, 1, 2, 3], [0, 0, 1, 1], water_time_s=2.0, sample_time_s=0.5,
    ...                                   structure="paper")
    >>> phi.tolist(), target.tolist(), ks.tolist()
    ([[1.0, 0.0, -0.0], [2.0, 1.0, -4.0]], [2.0, 3.0], [1, 2])
    """
    if structure not in HEAD_STRUCTURES:
        raise InputError(f"head structure must be one of {', '.join(HEAD_STRUCTURES)}, got {structure!r}")
    h = np.asarray(h, dtype=float)
    q = np.asarray(q, dtype=float)
    if h.shape != q.shape or h.ndim != 1:
        raise InputError(f"h and q must be 1-D of the same length, got {h.shape} and {q.shape}")
    for name, value in (("water_time_s", water_time_s), ("sample_time_s", sample_time_s)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise InputError(f"{name} must be a number > 0, got {value!r}")
    v = -water_time_s * np.diff(q) / sample_time_s  # v(j) over [j, j+1], j = 0..N-2
    if structure == "paper":
        ks = np.arange(1, h.size - 1)
        phi = np.column_stack([h[ks], h[ks - 1], v[ks - 1]])  # eq. (61): -Tw dq/dt(k-1) over [k-1, k]
    else:
        if isinstance(n_a, bool) or isinstance(n_b, bool) or not (isinstance(n_a, int) and isinstance(n_b, int)) \
                or n_a < 1 or n_b < 1:
            raise InputError(f"n_a and n_b must be integers >= 1, got {n_a!r}, {n_b!r}")
        k0 = max(n_a - 1, n_b - 1)
        ks = np.arange(k0, h.size - 1)
        # + q(k+1): the steady friction loss h = h_w - r_f q (the coefficient is -r_f (1 - sum a))
        phi = np.column_stack([h[ks - i] for i in range(n_a)] + [v[ks - j] for j in range(n_b)] + [q[ks + 1]])
    if ks.size < 1:
        raise InputError(f"{h.size} samples are too few for the head structure {structure!r}")
    return phi, h[ks + 1], ks


def head_simulation_mode(theta, h, q, *, water_time_s: float, sample_time_s: float, structure: str = "interval",
                         n_a: int = 2, n_b: int = 2) -> np.ndarray:
    """h_hat(k+1) = theta_h^T [h_hat(k), .., flow terms from the measured q] (eq. (65)); measured h only as the
    initial samples."""
    phi, _, ks = head_regressors(h, q, water_time_s=water_time_s, sample_time_s=sample_time_s,
                                 structure=structure, n_a=n_a, n_b=n_b)
    theta = np.asarray(theta, dtype=float)
    n_h = 2 if structure == "paper" else n_a
    h_hat = np.asarray(h, dtype=float).copy()
    with np.errstate(over="ignore", invalid="ignore"):  # divergence is checked and raised just below
        for row, k in zip(phi, ks):
            past = np.array([h_hat[k - i] for i in range(n_h)])
            h_hat[k + 1] = theta[:n_h] @ past + theta[n_h:] @ row[n_h:]  # eq. (65)
    if not np.all(np.isfinite(h_hat)):
        raise NumericalError("head model in simulation mode diverged: the identified head ARX is unstable")
    return h_hat


@dataclass(frozen=True, eq=False)
class HeadModelReport:
    """Speed and head models learned by RLS and the estimates of eqs. (62)-(68) on one relative series.

    ``summary`` (JSON-ready numbers), ``series`` {time_s, x, h, y, q, x_hat, h_hat, q_hat} arrays.
    """

    summary: dict
    series: dict = field(repr=False)

    def plot(self, path, *, title: str = "") -> None:
        """Measured and estimated speed, head and flow (paper 000 Figs. 7, 9-10 / 12-14 style)."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        s = self.series
        fig, axes = plt.subplots(4, 1, sharex=True, figsize=(9, 8.5))
        for ax, (key, label) in zip(axes, (("x", "speed x"), ("h", "head h"), ("q", "flow q"))):
            ax.plot(s["time_s"], 100 * s[key], color="tab:blue", lw=1.4, label="data")
            ax.plot(s["time_s"], 100 * s[key + "_hat"], color="tab:red", lw=1.0, ls="--", label="model")
            err = self.summary["errors_fraction_of_peak"][key]
            ax.set_ylabel(f"{label}, %")
            ax.set_title(f"{label}: max error {100 * err:.2f} % of the largest deviation", fontsize=9)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8, loc="upper right")
        axes[-1].plot(s["time_s"], 100 * s["y"], color="tab:green", lw=1.0)
        axes[-1].set_ylabel("opening y, %")
        axes[-1].set_xlabel("time (s)")
        axes[-1].grid(alpha=0.3)
        fig.suptitle(title or "Wang et al. (2023) estimates: speed (eqs. 62-63), head (eq. 65), flow (eq. 5)")
        fig.tight_layout()
        fig.savefig(path, dpi=100)
        plt.close(fig)


def head_model_report(time_s, x, h, y, q, m=None, *, water_time_s: float, sample_time_s: float,
                      structure: str = "interval", speed_order: int = 3, p0: float = 1e10) -> HeadModelReport:
    """Learn the speed ARX (ZOH structure, order ``speed_order``) and the head ARX by RLS (eqs. (57)-(59)), the six
    coefficients by batch LS when the torque ``m`` is given (else only eqs. (70) for the flow, from (x, h, y, q)),
    and evaluate the three estimates in simulation mode."""
    x, h, y, q = (np.asarray(a, dtype=float) for a in (x, h, y, q))
    structure_kw = {"n_a": speed_order, "n_b": speed_order, "input_delay": 0}
    phi, target = arx_regressors(x, y, **structure_kw)
    speed = RecursiveLeastSquares(p0=p0).fit(phi, target)
    x_hat = simulation_mode_output(speed.theta_, x, y, **structure_kw).x_hat  # eqs. (62)-(63)
    phi_h, target_h, _ = head_regressors(h, q, water_time_s=water_time_s, sample_time_s=sample_time_s,
                                         structure=structure)
    head = RecursiveLeastSquares(p0=p0).fit(phi_h, target_h)  # eqs. (57)-(59) on eq. (61)
    h_hat = head_simulation_mode(head.theta_, h, q, water_time_s=water_time_s, sample_time_s=sample_time_s,
                                 structure=structure)
    X = np.column_stack([x, h, y])
    if m is not None:
        six = SixCoefficientLeastSquares().fit(X, np.column_stack([np.asarray(m, dtype=float), q])).six_coefficients_
        eqx, eqy, eqh = six["eqx"], six["eqy"], six["eqh"]
    else:  # eq. (70) alone
        eqx, eqh, eqy = np.linalg.lstsq(X, q, rcond=None)[0]
        six = {"eqx": float(eqx), "eqy": float(eqy), "eqh": float(eqh)}
    q_hat = eqx * x_hat + eqy * y + eqh * h_hat  # eq. (5) with the estimated speed and head
    errors = {"x": _fraction(x - x_hat, x), "h": _fraction(h - h_hat, h), "q": _fraction(q - q_hat, q)}
    summary = {"structure": structure, "water_time_s": water_time_s, "sample_time_s": sample_time_s,
               "theta_speed": speed.theta_.tolist(), "theta_head": head.theta_.tolist(),
               "six_coefficients": six, "errors_fraction_of_peak": errors,
               "peaks": {"x": float(np.max(np.abs(x))), "h": float(np.max(np.abs(h))),
                         "q": float(np.max(np.abs(q)))}}
    series = {"time_s": np.asarray(time_s, dtype=float), "x": x, "h": h, "y": y, "q": q, "x_hat": x_hat,
              "h_hat": h_hat, "q_hat": q_hat}
    return HeadModelReport(summary=summary, series=series)


def relative_series(result, *, sample_time_s: float):
    """``(time_s, x, h, y, q, m)`` of a :class:`~simulate.results.result.SimulationResult` resampled to tau and relative
    to its first row (paper 000 eq. (3)); m is None when the initial torque is zero (no load)."""
    t = result.time_s
    grid = np.arange(0.0, t[-1] + 1e-9 * sample_time_s, sample_time_s)

    def rel(values):
        v = np.interp(grid, t, values)
        return v / v[0] - 1.0

    m = rel(result.torque_nm) if result.torque_nm[0] > 0 else None
    return grid, rel(result.speed_rpm), rel(result.head_m), rel(result.opening), rel(result.flow_m3_s), m


def open_loop_head_study(plant, *, penstock_model: str = "lumped", settings=None, initial_opening: float = 0.68,
                         structure: str = "interval", characteristics=None) -> HeadModelReport:
    """The open-loop experiment of :mod:`simulate.identification.experiment` (opening steps + PRBS) on the nonlinear
    simulator, then :func:`head_model_report` (paper 000 Figs. 9-10)."""
    from simulate.identification.experiment import ExperimentSettings, experiment_plant
    from simulate.loop.engine import run_simulation

    settings = settings or ExperimentSettings()
    run_plant = experiment_plant(plant, settings, initial_stroke=initial_opening, penstock_model=penstock_model)
    result = run_simulation(run_plant, characteristics)
    t, x, h, y, q, m = relative_series(result, sample_time_s=settings.sample_time_s)
    tw = run_plant.penstock.inertance_s2_m2 * result.flow_m3_s[0] / result.head_m[0]  # Tw at O
    report = head_model_report(t, x, h, y, q, m, water_time_s=tw, sample_time_s=settings.sample_time_s,
                               structure=structure)
    report.summary.update({"penstock_model": penstock_model, "initial_opening": initial_opening})
    return report


# ----------------------------------------------------------------------------------------------------------------
# closed loop
# ----------------------------------------------------------------------------------------------------------------


def closed_loop_eigenvalues(linear, *, kp_relative: float, ti_s: float, servo_time_s: float) -> np.ndarray:
    """Eigenvalues (1/s) of the nets' linear plant (:class:`simulate.linear.models.LinearPlant`) with the governor
    u = -Kp (x + (1/TI) int x) (relative opening per relative speed, as paper 000 tests 5-6) and the first-order
    servo T_y y' = u - y. States [X~ (plant, single-input form), integral, y]."""
    a, b, _, _ = linear.state_space().single_input()
    n = a.shape[0]
    m = np.zeros((n + 2, n + 2))
    m[:n, :n], m[:n, n + 1] = a, b[:, 0]
    m[n, 0] = -kp_relative / ti_s  # integral of -Kp/TI x
    m[n + 1, 0] = -kp_relative / servo_time_s
    m[n + 1, n] = 1.0 / servo_time_s
    m[n + 1, n + 1] = -1.0 / servo_time_s
    return np.linalg.eigvals(m)


def linear_closed_loop(linear, *, kp_relative: float, ti_s: float, sample_time_s: float, n_samples: int,
                       reference=None, load=None, servo=None) -> dict:
    """Discrete closed loop on the ZOH of the linear plant at tau: PI on e = r - x (rectangle integral), the eq. (37)
    servo (:mod:`simulate.components.control.discrete_servo`, default the printed one) driving the relative opening,
    ``load`` the relative load torque m_g0(k). Returns {"x", "y", "r", "d"} arrays (n_samples + 1)."""
    from simulate.components.control.discrete_servo import (DiscreteServoConfig, discrete_servo_parameters,
                                                            discrete_servo_step)

    servo = servo or DiscreteServoConfig(sample_time_s=sample_time_s)
    ss = linear.state_space()
    disc = ss.discretize(sample_time_s)
    r = np.zeros(n_samples + 1) if reference is None else np.asarray(reference, dtype=float)
    d = np.zeros(n_samples + 1) if load is None else np.asarray(load, dtype=float)
    p = discrete_servo_parameters(servo)
    p[4], p[5] = -np.inf, np.inf  # relative increments: no stroke limits in the linear loop
    s = np.zeros(3)
    state = np.zeros(ss.A.shape[0])
    integral = 0.0
    x = np.zeros(n_samples + 1)
    y = np.zeros(n_samples + 1)
    y_prev = 0.0
    for k in range(n_samples + 1):
        x[k] = state[0]
        e = r[k] - x[k]
        integral += kp_relative / ti_s * e * sample_time_s
        y[k] = discrete_servo_step(p, s, kp_relative * e + integral, sample_time_s)  # eq. (37)
        # X(k+1) = G X(k) + H_B1 y(k) + B2 (y(k) - y(k-1)) jump at k, + H_L m_g0 (simulate.linear.models docstring)
        state = state + disc.B2 * (y[k] - y_prev)
        state = disc.G @ state + disc.HB1 * y[k] + disc.HL * d[k]
        y_prev = y[k]
        if not np.all(np.isfinite(state)) or np.max(np.abs(state)) > 1e6:
            raise NumericalError(f"closed loop diverged at sample {k} (Kp {kp_relative}, TI {ti_s} s)")
    return {"x": x, "y": y, "r": r, "d": d}


def direct_arx_identification(x, y, reference_arx: ArxModel, *, order: int = 3, n_step: int = 130,
                              extra=None) -> dict:
    """Direct closed-loop identification: least squares of the ZOH-structure ARX on (x, y) (plus ``extra``
    regressor columns aligned with the rows, e.g. a known load), compared with ``reference_arx`` by step
    response. Returns theta, condition number of the regressors, step error (fraction of the reference peak)."""
    phi, target = arx_regressors(x, y, n_a=order, n_b=order, input_delay=0)
    if extra is not None:
        phi = np.column_stack([phi, np.asarray(extra, dtype=float)[order - 1: order - 1 + phi.shape[0]]])
    theta = np.linalg.lstsq(phi, target, rcond=None)[0]
    model = ArxModel.from_theta(theta[:2 * order], n_a=order, n_b=order)
    step = model.step_response(n_step)
    ref = reference_arx.step_response(n_step)
    err = float(np.max(np.abs(step - ref)) / np.max(np.abs(ref))) if np.all(np.isfinite(step)) else float("inf")
    return {"theta": theta.tolist(), "condition_number": float(np.linalg.cond(phi)), "step_error": err}


def closed_loop_identification(plant, *, kp_relative: float = 7.5, ti_s: float = 0.5, initial_opening: float = 0.68,
                               load_step: float = 0.01, t_end_s: float = 100.0, sample_time_s: float = 0.2,
                               prbs_amplitude: float = 0.002, seed: int = 0, noise_level: float = 0.0,
                               characteristics=None, head_theta=None) -> dict:
    """Closed-loop identification, on the nonlinear simulator and on the nets' linear plant.

    1. Stability: eigenvalues of the linear closed loop with the PI (relative Kp, TI as paper 000 tests 5-6) and the
       plant's first-order servo.
    2. Nonlinear simulator (``load-step`` scenario through :func:`simulate.loop.engine.run_simulation`, governor PI with
       kp = Kp y0 stroke per unit speed, ki = kp / TI, kd = 0): direct ARX on (x, y), with and without the known
       load step as a regressor. The only excitation is one load step.
    3. Linear closed loop at tau (:func:`linear_closed_loop`, eq. (37) servo) (a) with the same load step only,
       (b) with a seeded PRBS of +-``prbs_amplitude`` on the speed reference (external excitation), optional
       uniform measurement noise on x.
    4. Head model (interval structure) on the simulator's closed-loop run: learned on that run by RLS, and, when
       ``head_theta`` (e.g. learned open loop) is given, that model applied to it; simulation-mode errors (eq. (65))
       as fractions of the largest head deviation.

    Identifiability under feedback (Ljung 1999, section 13.4; Soderstrom and Stoica 1989, chapter 10): with a
    linear time-invariant regulator and no external signal, u(k) is a fixed filter of x, so the regressors of an
    ARX whose orders exceed the regulator's are (nearly) linearly dependent: the data cannot separate plant from
    regulator. A persistently exciting reference (or dither) restores identifiability; a single step does not.
    """
    from simulate.identification.linear_reference import linear_reference
    from simulate.components.turbine.component import characteristics_of
    from simulate.config import ScenarioConfig
    from simulate.loop.engine import initial_state, run_simulation

    chars = characteristics_of(plant, characteristics)
    base = replace(plant, scenario=ScenarioConfig(kind="load-step", t_end_s=t_end_s, initial_opening=initial_opening,
                                                  event_time_s=5.0, load_step=load_step),
                   penstock=replace(plant.penstock, model="lumped"),
                   solver=replace(plant.solver, dt_s=sample_time_s / 10))
    steady = initial_state(base, chars)
    _, linear = linear_reference(base, chars, steady)
    ref = linear.arx(sample_time_s)
    eig = closed_loop_eigenvalues(linear, kp_relative=kp_relative, ti_s=ti_s,
                                  servo_time_s=plant.governor.servo_time_s)
    out: dict = {"kp_relative": kp_relative, "ti_s": ti_s, "initial_stroke": steady.stroke,
                 "governor_kp_stroke": kp_relative * steady.stroke, "governor_ki": kp_relative * steady.stroke / ti_s,
                 "closed_loop_max_real_eigenvalue": float(np.max(eig.real)),
                 "closed_loop_stable": bool(np.max(eig.real) < 0)}
    kp = kp_relative * steady.stroke
    run_plant = replace(base, governor=replace(base.governor, kp=kp, ki=kp / ti_s, kd=0.0, permanent_droop=0.0))
    result = run_simulation(run_plant, chars, raise_on_failure=False)
    t, x, h, y, q, m = relative_series(result, sample_time_s=sample_time_s)
    d = np.where(t >= 5.0 - 1e-9, load_step, 0.0)
    out["simulator"] = {"max_abs_x": float(np.max(np.abs(x))), "max_abs_y": float(np.max(np.abs(y))),
                        "stroke_saturated": bool(np.max(result.opening) >= plant.governor.stroke_max - 1e-9),
                        "without_load": direct_arx_identification(x, y, ref),
                        "with_known_load": direct_arx_identification(x, y, ref, extra=d)}
    tw = run_plant.penstock.inertance_s2_m2 * result.flow_m3_s[0] / result.head_m[0]
    phi_h, target_h, _ = head_regressors(h, q, water_time_s=tw, sample_time_s=sample_time_s)
    learned = RecursiveLeastSquares(p0=1e10).fit(phi_h, target_h).theta_
    head_out = {"theta_learned_closed_loop": learned.tolist()}
    for label, theta in (("learned_closed_loop", learned), ("given", head_theta)):
        if theta is None:
            continue
        try:
            h_hat = head_simulation_mode(theta, h, q, water_time_s=tw, sample_time_s=sample_time_s)
            head_out[f"error_{label}"] = _fraction(h - h_hat, h)
        except NumericalError as exc:  # an unstable head model is a result
            head_out[f"error_{label}"] = str(exc)
    out["simulator"]["head_model"] = head_out
    n = int(round(t_end_s / sample_time_s))
    linear_out = {}
    if out["closed_loop_stable"]:
        tt = sample_time_s * np.arange(n + 1)
        load = np.where(tt >= 5.0 - 1e-9, load_step, 0.0)
        only_load = linear_closed_loop(linear, kp_relative=kp_relative, ti_s=ti_s, sample_time_s=sample_time_s,
                                       n_samples=n, load=load)
        linear_out["load_step_only"] = direct_arx_identification(only_load["x"], only_load["y"], ref,
                                                                 extra=only_load["d"])
        rng = np.random.default_rng(seed)
        bits = np.repeat(rng.choice([-1.0, 1.0], size=n // 5 + 1), 5)[: n + 1] * prbs_amplitude  # 1 s bits
        excited = linear_closed_loop(linear, kp_relative=kp_relative, ti_s=ti_s, sample_time_s=sample_time_s,
                                     n_samples=n, reference=bits)
        xs = excited["x"] + (rng.uniform(-noise_level, noise_level, n + 1) if noise_level > 0 else 0.0)
        linear_out["reference_prbs"] = direct_arx_identification(xs, excited["y"], ref)
        linear_out["reference_prbs"]["noise_level"] = noise_level
    out["linear_closed_loop"] = linear_out
    return out


def check_closed_loop_options(kp, ti_values) -> None:
    """:class:`InputError` unless Kp (relative) and every TI (s) are finite numbers in (0, 1000]; ``ti_values``
    None: the default integral times. Integral times without Kp are refused (they would be ignored)."""
    if kp is None:
        if ti_values is not None:
            raise InputError(f"--closed-loop-ti {' '.join(f'{v:g}' for v in ti_values)} needs --closed-loop-kp "
                             "(the closed-loop runs use the governor PI with that Kp); add --closed-loop-kp KP or "
                             "drop --closed-loop-ti")
        return
    if isinstance(kp, bool) or not isinstance(kp, (int, float)) or not (math.isfinite(kp) and 0 < kp <= 1000):
        raise InputError(f"--closed-loop-kp must be a number in (0, 1000], got {kp!r}")
    for ti in DEFAULT_CLOSED_LOOP_TI if ti_values is None else ti_values:
        if isinstance(ti, bool) or not isinstance(ti, (int, float)) or not (math.isfinite(ti) and 0 < ti <= 1000):
            raise InputError(f"--closed-loop-ti values must be numbers in (0, 1000] s, got {ti!r}")


#: Integral times (s) of the closed-loop identification runs when none are given.
DEFAULT_CLOSED_LOOP_TI = (0.5, 0.15)


def write_head_and_closed_loop(report, plant, out_dir, *, head_structure: str | None = None,
                               closed_loop_kp: float | None = None, closed_loop_ti=DEFAULT_CLOSED_LOOP_TI) -> dict:
    """``hillsim identify`` extras: the head model on the report's series (``head_model.json``, ``head_model.png``)
    and closed-loop identification runs (``closed_loop.json``), one per integral time. Returns the paths."""
    import json
    from pathlib import Path

    from simulate.results.result import json_default

    out = Path(out_dir)
    paths = {}
    if head_structure is not None:
        s = report.series
        op = s.operating_point
        tw = plant.penstock.inertance_s2_m2 * op.flow_m3_s / op.head_m  # Tw at O
        head = head_model_report(s.time_s, s.x, s.h, s.y, s.q, s.m, water_time_s=tw,
                                 sample_time_s=s.sample_time_s, structure=head_structure)
        paths["head_model_json"] = out / "head_model.json"
        paths["head_model_json"].write_text(json.dumps(head.summary, indent=2, default=json_default) + "\n",
                                            encoding="utf-8")
        paths["head_model_png"] = out / "head_model.png"
        head.plot(paths["head_model_png"])
        head_theta = head.summary["theta_head"] if head_structure == "interval" else None
        err = head.summary["errors_fraction_of_peak"]
        print(f"head model ({head_structure}): simulation-mode errors, fraction of the largest deviation: speed "
              f"{err['x']:.4f}, head {err['h']:.4f}, flow {err['q']:.4f}")
    else:
        head_theta = None
    if closed_loop_kp is not None:
        check_closed_loop_options(closed_loop_kp, closed_loop_ti)
        runs = []
        for ti in closed_loop_ti:
            r = closed_loop_identification(plant, kp_relative=closed_loop_kp, ti_s=ti, head_theta=head_theta)
            runs.append(r)
            lin = r["linear_closed_loop"].get("reference_prbs", {})
            print(f"closed loop Kp {closed_loop_kp}, TI {ti} s: {'stable' if r['closed_loop_stable'] else 'UNSTABLE'}"
                  f" (max Re lambda {r['closed_loop_max_real_eigenvalue']:.3g} 1/s); load step only: step error "
                  f"{r['simulator']['with_known_load']['step_error']:.3g}; reference PRBS (linear plant): "
                  f"{lin.get('step_error', float('nan')):.3g}")
        paths["closed_loop_json"] = out / "closed_loop.json"
        paths["closed_loop_json"].write_text(json.dumps(runs, indent=2, default=json_default) + "\n",
                                             encoding="utf-8")
    return paths


__all__ = ["HEAD_STRUCTURES", "write_head_and_closed_loop", "check_closed_loop_options", "head_regressors",
           "head_simulation_mode", "HeadModelReport", "head_model_report",
           "relative_series", "open_loop_head_study", "closed_loop_eigenvalues", "linear_closed_loop",
           "direct_arx_identification", "closed_loop_identification"]
