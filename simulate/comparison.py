"""What the nets say the linear turbine is, against what identification finds from the nonlinear transient.

:func:`compare_identification` runs the nonlinear simulator in open loop around the plant's operating point (opening
steps of +-1 % and a seeded PRBS, then a quiet tail), samples the run at tau (0.2 s, paper 000 section 5), optionally
adds seeded bounded measurement noise, and identifies:

- the six coefficients by batch least squares (paper 000 eqs. (69)-(70)) from (x, h, y, m, q), against the nets'
  analytic values (:func:`hillchart.linearize.six_coefficients`) and, for the synthetic chart, the exact turbine's;
- the ARX speed model (eq. (53)) by RLS (eqs. (57)-(59)), RLS with forgetting and dead-zone RLS (paper 001 eqs.
  (5)-(8)), against the ARX that the zero-order hold of the nets' linear plant implies (eqs. (32)-(36)); compared
  by step responses (ARX parameters are ill-conditioned) and by the simulation-mode speed error (eqs. (62)-(64));
- paper 002's (ey, e, eqh) by ARMA least squares (eqs. (9)-(12)) on the torque with the speed term removed.

:func:`identify_measured` does the identification part on a measured series (CSV), resampled to tau by linear
interpolation as in paper 000 section 5. Everything returns an :class:`IdentificationReport` record;
files are written only by :meth:`IdentificationReport.write`.

Relative variables (paper 000 eq. (3)) are taken about the verified initial steady state O of the run:
``x = n/n0 - 1``, ``h = H/H0 - 1``, ``y = a/a0 - 1``, ``m = M/M0 - 1``, ``q = Q/Q0 - 1``. The simulator's per-unit
rotor ``Ta dx/dt = (M - M_g)/M_r - e_g x`` (torque base M_r = P_r/omega_r) becomes the paper's
``J dx/dt = m - m_L`` with ``J = Ta M_r / M0`` and grid damping ``e_g M_r / M0``; the water time at O is
``Tw = sum L_i/(g A_i) Q0/H0`` and the linearized friction slope ``r_f = 2 K Q0^2 / H0``.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from hillchart.errors import InputError, NumericalError
from hillchart.linearize import COEFFICIENT_NAMES, six_coefficients
from simulate.identify import (
    ArmaLeastSquares,
    DeadZoneRLS,
    RecursiveLeastSquares,
    SixCoefficientLeastSquares,
    arx_regressors,
    arx_start,
    simulation_mode_output,
)
from simulate.linear import ArxModel, LinearPlant, combined_coefficient
from simulate.result import json_default

#: Acceptance bounds of issue 5 (checked and reported, never silently relaxed).
BATCH_LS_TOLERANCE = 0.02  # absolute, each of the six coefficients, noise-free small signal
STEP_RESPONSE_TOLERANCE = 0.05  # max |step_rls - step_nets| / max |step_nets|
SIMULATION_MODE_TOLERANCE = 0.05  # max |x - x_hat| / max |x|: a fraction of the largest measured speed deviation
#: Recursive estimators the acceptance judges (each on step response and simulation mode).
JUDGED_ESTIMATORS = ("rls", "rls_forgetting", "dead_zone_rls")

#: CSV columns ``--data`` needs (units in the names; extra columns are ignored). ``opening`` is any unit
#: proportional to the chart opening (stroke fraction or chart units): only a/a0 is used.
MEASURED_COLUMNS = ("time_s", "speed_rpm", "head_m", "opening", "torque_nm", "flow_m3_s")


# ----------------------------------------------------------------------------------------------------------------
# settings
# ----------------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ExperimentSettings:
    """The identification experiment (all times in s; amplitudes are relative openings y = da/a0).

    Attributes
    ----------
    sample_time_s : float
        tau, the sampling of the identification data (paper 000: 0.2 s).
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
        see :class:`simulate.identify.RecursiveLeastSquares`).
    forgetting_factor : float
        lambda of the "RLS with forgetting" estimator (the plain RLS uses 1).
    dead_zone_eps0 : float or None
        Dead zone on the a-priori residual; None: 2 (1 + sum |a_i|) noise_level (the equation-error bound, doubled),
        or 1e-7 without noise.
    dead_zone_delta : float
        delta of paper 001 eq. (8).
    arx_structure : str
        ``"zoh"`` (n_a = n_b = model order, no delay: the exact zero-order hold) or ``"paper"`` (eq. (53) as printed:
        n_a = 3, n_b = 2, one sample delay). The other one is always reported too.
    arma_sample_time_s : float
        Sampling of the paper 002 ARMA fit (its eq. (6) is a backward difference, biased by about
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


# ----------------------------------------------------------------------------------------------------------------
# operating point and linear reference
# ----------------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class OperatingPoint:
    """The point O the relative variables refer to (physical units)."""

    speed_rpm: float
    head_m: float
    flow_m3_s: float
    torque_nm: float
    opening: float  # same unit as the opening series (stroke fraction for simulated runs)

    def __post_init__(self):
        for name in ("speed_rpm", "head_m", "flow_m3_s", "torque_nm", "opening"):
            value = getattr(self, name)
            if not math.isfinite(value) or value <= 0:
                raise InputError(f"operating point {name} must be finite and > 0 (relative variables divide by it), "
                                 f"got {value!r}")


def linear_reference(plant, characteristics, steady, *, penstock_model: str | None = None):
    """``(coefficients, LinearPlant)`` the nets predict at the steady state of a plant (see module docstring).

    Parameters
    ----------
    plant : simulate.config.PlantConfig
    characteristics : Characteristics
        The nets (or any characteristics) the simulator uses.
    steady : simulate.steady.SteadyState
        Verified initial state of the run.
    penstock_model : str, optional
        ``"rigid"`` gives the inelastic model (eqs. 10-12); anything else the lumped elastic model (eqs. 24-30) with
        Te = sum L/a and the plant's lumped_alpha. Default: the plant's own model.
    """
    turbine, pen, gen = plant.turbine, plant.penstock, plant.generator
    model = penstock_model or pen.model
    n11 = steady.speed_rpm * turbine.runner_diameter_m / math.sqrt(steady.head_m)  # N11 = n D1 / sqrt(H)
    coeffs = six_coefficients(characteristics, n11=n11, opening=steady.opening_chart)
    torque_ratio = turbine.rated_torque_nm / steady.torque_nm  # M_r / M0
    linear = LinearPlant.from_coefficients(
        coeffs,
        water_time_s=pen.inertance_s2_m2 * steady.flow_m3_s / steady.head_m,  # Tw = L Q0 / (g A H0), eq. (9)
        inertia_time_s=gen.inertia_time_s * torque_ratio * steady.speed_rpm / turbine.rated_speed_rpm,
        self_regulation=(plant.rotor_self_regulation(steady.torque_nm / turbine.rated_torque_nm) * torque_ratio
                         * steady.speed_rpm / turbine.rated_speed_rpm),
        wave_time_s=0.0 if model == "rigid" else pen.travel_time_s,
        alpha=pen.lumped_alpha,
        friction_slope=2.0 * pen.friction_coefficient_s2_m5 * steady.flow_m3_s**2 / steady.head_m,
    )
    return coeffs, linear


def plant_linearization(plant, characteristics=None, *, initial_opening: float | None = None,
                        penstock_model: str | None = None, sample_time_s: float = 0.2) -> dict:
    """The nets' linear model at a plant's verified initial operating point, as a JSON-ready dict.

    Operating point: ``initial_opening`` (stroke fraction) or the plant scenario's initial power/opening. Returns
    the operating point, the six coefficients, the linear-plant parameters (Tw, J, e_g, Te, alpha, r_f), the
    eigenvalues of A and open-loop stability, the speed transfer function N/D and the ARX at ``sample_time_s``.
    """
    from dataclasses import replace as _replace

    from simulate.config import ScenarioConfig, load_characteristics
    from simulate.engine import initial_state

    chars = load_characteristics(plant.turbine, plant.base_dir) if characteristics is None else characteristics
    if initial_opening is not None:
        plant = _replace(plant, scenario=ScenarioConfig(kind="opening-steps", t_end_s=10.0,
                                                        initial_opening=initial_opening))
    elif plant.scenario.kind == "frequency-steps":
        raise InputError("the plant's scenario is frequency-steps (no load): give an initial opening")
    steady = initial_state(plant, chars)
    coeffs, linear = linear_reference(plant, chars, steady, penstock_model=penstock_model)
    ss = linear.state_space()
    num, den = linear.speed_transfer_function()
    return {
        "operating_point": {"speed_rpm": steady.speed_rpm, "head_m": steady.head_m, "flow_m3_s": steady.flow_m3_s,
                            "torque_nm": steady.torque_nm, "power_mw": steady.power_mw, "stroke": steady.stroke,
                            "opening_chart": steady.opening_chart, "n11_rpm": coeffs.n11_rpm},
        "coefficients": {k: getattr(coeffs, k) for k in COEFFICIENT_NAMES},
        "e": coeffs.e,
        "linear_model": {"kind": "elastic (lumped, eqs. 24-30)" if linear.elastic else "inelastic (eqs. 10-12)",
                         "water_time_s": linear.water_time_s, "inertia_time_s": linear.inertia_time_s,
                         "self_regulation": linear.self_regulation, "wave_time_s": linear.wave_time_s,
                         "alpha": linear.alpha, "friction_slope": linear.friction_slope,
                         "eigenvalues": [[float(v.real), float(v.imag)] for v in ss.eigenvalues()],
                         "open_loop_stable": ss.is_stable(),
                         "speed_tf": {"num": num.tolist(), "den": den.tolist()},
                         "arx": linear.arx(sample_time_s).to_dict()},
    }


# ----------------------------------------------------------------------------------------------------------------
# series
# ----------------------------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class RelativeSeries:
    """Uniformly sampled relative series (paper 000 eq. (3)); each array has shape (N,)."""

    time_s: np.ndarray
    x: np.ndarray
    h: np.ndarray
    y: np.ndarray
    m: np.ndarray
    q: np.ndarray
    sample_time_s: float
    operating_point: OperatingPoint

    @classmethod
    def from_physical(cls, time_s, speed_rpm, head_m, opening, torque_nm, flow_m3_s, *, sample_time_s: float,
                      operating_point: OperatingPoint | None = None, t_start_s: float | None = None):
        """Resample physical series to ``sample_time_s`` by linear interpolation (paper 000 section 5) and make
        them relative to ``operating_point`` (default: the first sample).

        Examples
        --------
        >>> t = np.arange(51) * 0.1                       # 10 Hz sensor, 5 s
        >>> s = RelativeSeries.from_physical(t, 200 + 2 * t, 100 + 0 * t, 0.5 + 0 * t, 1e6 + 0 * t, 50 + 0 * t,
        ...                                  sample_time_s=0.5)
        >>> s.time_s[:3].tolist(), [round(float(v), 12) for v in s.x[:3]]
        ([0.0, 0.5, 1.0], [0.0, 0.005, 0.01])
        """
        t = np.asarray(time_s, dtype=float)
        series = {"speed_rpm": speed_rpm, "head_m": head_m, "opening": opening, "torque_nm": torque_nm,
                  "flow_m3_s": flow_m3_s}
        arrays = {}
        for name, values in series.items():
            arr = np.asarray(values, dtype=float)
            if arr.shape != t.shape:
                raise InputError(f"{name} must have as many samples as time_s ({t.size}), got {arr.size}")
            if not np.all(np.isfinite(arr)):
                raise InputError(f"{name} contains a non-finite value at row {int(np.argmax(~np.isfinite(arr)))}")
            arrays[name] = arr
        if t.ndim != 1 or t.size < 10:
            raise InputError(f"time_s must be one-dimensional with at least 10 samples, got shape {t.shape}")
        if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise InputError("time_s must be finite and strictly increasing")
        tau = float(sample_time_s)
        start = float(t[0]) if t_start_s is None else float(t_start_s)
        n = int(math.floor((t[-1] - start) / tau + 1e-9)) + 1
        if n < 10:
            raise InputError(f"the series lasts {t[-1] - start:.6g} s: fewer than 10 samples at tau = {tau} s")
        grid = start + tau * np.arange(n)
        res = {name: np.interp(grid, t, arr) for name, arr in arrays.items()}
        if operating_point is None:
            operating_point = OperatingPoint(speed_rpm=arrays["speed_rpm"][0], head_m=arrays["head_m"][0],
                                             flow_m3_s=arrays["flow_m3_s"][0], torque_nm=arrays["torque_nm"][0],
                                             opening=arrays["opening"][0])
        op = operating_point
        return cls(time_s=grid - grid[0], x=res["speed_rpm"] / op.speed_rpm - 1.0, h=res["head_m"] / op.head_m - 1.0,
                   y=res["opening"] / op.opening - 1.0, m=res["torque_nm"] / op.torque_nm - 1.0,
                   q=res["flow_m3_s"] / op.flow_m3_s - 1.0, sample_time_s=tau, operating_point=op)

    def with_noise(self, level: float, seed: int) -> "RelativeSeries":
        """A copy with uniform noise in [-level, level] added to x, h, m, q (the opening is the command)."""
        if level == 0:
            return self
        rng = np.random.default_rng(seed)
        noisy = {k: getattr(self, k) + rng.uniform(-level, level, self.x.size) for k in ("x", "h", "m", "q")}
        return replace(self, **noisy)


def load_measured_series(path, *, sample_time_s: float, operating_point: OperatingPoint | None = None):
    """Read a measured series CSV and resample it (paper 000 section 5).

    The file has one header line naming the columns with their units (:data:`MEASURED_COLUMNS`: ``time_s,
    speed_rpm, head_m, opening, torque_nm, flow_m3_s``; other columns are ignored, so ``timeseries.csv`` from
    ``hillsim run`` works as is), then one numeric row per sample, time strictly increasing. The sensors may be
    sampled at any rate; every column is interpolated linearly onto the tau grid.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(f"cannot read series file {str(path)!r}: {exc.strerror}") from None
    rows = list(csv.reader(text.splitlines()))
    if not rows:
        raise InputError(f"{path}: empty file; expected a header line {','.join(MEASURED_COLUMNS)}")
    header = [h.strip() for h in rows[0]]
    missing = [c for c in MEASURED_COLUMNS if c not in header]
    if missing:
        raise InputError(f"{path}: missing column {missing[0]!r}; the header must name {', '.join(MEASURED_COLUMNS)} "
                         f"(units in the names), got {', '.join(header)}")
    idx = [header.index(c) for c in MEASURED_COLUMNS]
    data = []
    for line_no, row in enumerate(rows[1:], start=2):
        if not row or all(not cell.strip() for cell in row):
            continue
        if len(row) != len(header):
            raise InputError(f"{path}: line {line_no} has {len(row)} fields, the header has {len(header)}")
        try:
            data.append([float(row[i]) for i in idx])
        except ValueError:
            bad = next(header[i] for i in idx if not _is_float(row[i]))
            raise InputError(f"{path}: line {line_no}, column {bad!r} is not a number: "
                             f"{row[header.index(bad)]!r}") from None
    if len(data) < 10:
        raise InputError(f"{path}: needs at least 10 data rows, got {len(data)}")
    arr = np.array(data)
    try:
        return RelativeSeries.from_physical(*arr.T, sample_time_s=sample_time_s, operating_point=operating_point)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


def _is_float(text: str) -> bool:
    try:
        float(text)
        return True
    except ValueError:
        return False


# ----------------------------------------------------------------------------------------------------------------
# identification on a series
# ----------------------------------------------------------------------------------------------------------------


def _arx_structure(kind: str, order: int) -> dict:
    if kind == "zoh":
        return {"n_a": order, "n_b": order, "input_delay": 0}
    return {"n_a": 3, "n_b": 2, "input_delay": 1}  # paper 000 eq. (53) as printed


def _step_error(model: ArxModel, reference: ArxModel, n_samples: int) -> float:
    s_model = model.step_response(n_samples)
    s_ref = reference.step_response(n_samples)
    return float(np.max(np.abs(s_model - s_ref)) / np.max(np.abs(s_ref)))


@dataclass(frozen=True, eq=False)
class IdentificationReport:
    """Everything :func:`compare_identification` / :func:`identify_measured` found (JSON-ready via to_dict).

    Attributes
    ----------
    summary : dict
        The numbers (see :meth:`to_dict`); ``summary["acceptance"]`` holds the issue's checks when a nets
        reference is available.
    series : RelativeSeries
        The (noisy) identification data.
    histories : dict
        ``{estimator: theta_history (N, p)}`` for the convergence plot.
    step_responses : dict
        ``{label: ndarray}`` of the compared step responses (per unit opening step), with ``"time_s"``.
    simulation_mode : dict
        ``{label: x_hat}``.
    simulation : object or None
        The :class:`~simulate.result.SimulationResult` of the nonlinear run (None for measured data).
    """

    summary: dict
    series: RelativeSeries
    histories: dict
    step_responses: dict
    simulation_mode: dict
    simulation: object = None

    def to_dict(self) -> dict:
        return json.loads(json.dumps(self.summary, default=json_default))

    def write(self, out_dir) -> dict[str, Path]:
        """Write ``identification.json``, ``series.csv`` and the figures into ``out_dir``; returns the paths."""
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        paths = {"json": out / "identification.json", "series": out / "identified_series.csv"}
        paths["json"].write_text(json.dumps(self.to_dict(), indent=2) + "\n", encoding="utf-8")
        s = self.series
        np.savetxt(paths["series"], np.column_stack([s.time_s, s.x, s.h, s.y, s.m, s.q]), delimiter=",",
                   header="time_s,x,h,y,m,q", comments="", fmt="%.12g")
        paths.update(plot_report(self, out))
        return paths


def identify_series(series: RelativeSeries, settings: ExperimentSettings, *, reference: LinearPlant | None = None,
                    reference_coefficients=None, exact_coefficients=None, model_order: int | None = None,
                    arma_series: RelativeSeries | None = None, penstock_matches: bool = True) -> dict:
    """Run every estimator on ``series`` and compare with the nets' linear plant when given.

    Returns the pieces of an :class:`IdentificationReport` as a dict (summary, histories, step_responses,
    simulation_mode).
    """
    tau = series.sample_time_s
    order = model_order if model_order is not None else (reference.state_space().A.shape[0] if reference else 3)
    main = _arx_structure(settings.arx_structure, order)
    other = _arx_structure("paper" if settings.arx_structure == "zoh" else "zoh", order)
    x, u = series.x, series.y
    summary: dict = {"sample_time_s": tau, "samples": int(x.size), "arx_structure": main,
                     "peak_abs_x": float(np.max(np.abs(x)))}

    # --- six coefficients, batch least squares (paper 000 eqs. 69-70) -------------------------------------------
    batch = SixCoefficientLeastSquares().fit(np.column_stack([series.x, series.h, series.y]),
                                             np.column_stack([series.m, series.q]))
    six = {"batch_ls": batch.six_coefficients_, "condition_number": batch.condition_number_,
           "residual_rms": {"m": float(batch.residual_rms_[0]), "q": float(batch.residual_rms_[1])}}
    if reference_coefficients is not None:
        nets = {k: float(getattr(reference_coefficients, k)) for k in COEFFICIENT_NAMES}
        six["nets"] = nets
        six["batch_ls_minus_nets"] = {k: six["batch_ls"][k] - nets[k] for k in COEFFICIENT_NAMES}
        six["max_abs_batch_ls_minus_nets"] = max(abs(v) for v in six["batch_ls_minus_nets"].values())
    if exact_coefficients is not None:
        exact = {k: float(getattr(exact_coefficients, k)) for k in COEFFICIENT_NAMES}
        six["exact"] = exact
        if reference_coefficients is not None:
            six["max_abs_nets_minus_exact"] = max(abs(six["nets"][k] - exact[k]) for k in COEFFICIENT_NAMES)
        six["max_abs_batch_ls_minus_exact"] = max(abs(six["batch_ls"][k] - exact[k]) for k in COEFFICIENT_NAMES)
    summary["six_coefficients"] = six

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
    arx_out: dict = {"dead_zone_eps0": eps0, "forgetting_factor": settings.forgetting_factor,
                     "rls_p0": settings.rls_p0}
    histories: dict = {}
    sim_mode: dict = {}
    horizon_s = 60.0
    if reference is not None:
        slow = min(abs(np.real(reference.state_space().eigenvalues())))
        horizon_s = 6.0 / slow  # six slowest time constants: the step has settled to 0.25 %
    n_step = max(10, int(round(horizon_s / tau)))
    steps = {"time_s": tau * np.arange(n_step + 1)}
    if nets_arx is not None:
        arx_out["nets_zoh"] = nets_arx.to_dict() | {"theta": nets_arx.theta.tolist()}
        steps["nets_zoh"] = nets_arx.step_response(n_step)
    for label, structure in (("", main), ("paper_eq53_", other) if settings.arx_structure == "zoh"
                             else ("zoh_", other)):
        phi, target = arx_regressors(x, u, **structure)
        for name, make in estimators.items():
            if label and name != "rls":
                continue  # the alternative structure: plain RLS only
            est = make().fit(phi, target)
            model = ArxModel.from_theta(est.theta_, **structure, sample_time_s=tau)
            entry = {"theta": est.theta_.tolist(), "updates": int(est.n_updates_), **structure}
            final = simulation_mode_output(est.theta_, x, u, **structure)
            entry["simulation_mode_final_theta"] = final.to_dict()
            try:
                online = simulation_mode_output(est.theta_prior_, x, u, **structure)
                entry["simulation_mode_online"] = online.to_dict()
            except NumericalError as exc:  # an on-line model that diverges is a result: recorded
                entry["simulation_mode_online"] = {"error": str(exc)}
            k0 = arx_start(structure["n_a"], structure["n_b"], structure["input_delay"])
            tail = est.theta_history_[-int(min(len(est.theta_history_), round(settings.quiet_s / tau) or 1)):]
            entry["theta_spread_quiet_tail"] = float(np.max(np.linalg.norm(tail - tail[0], axis=1)))
            if nets_arx is not None:
                entry["step_error_vs_nets"] = _step_error(model, nets_arx, n_step)
                steps[label + name] = model.step_response(n_step)
            if not label:
                histories[name] = est.theta_history_
                sim_mode[name] = final.x_hat
                sim_mode["_k0"] = k0
            arx_out[label + name] = entry
    summary["arx"] = arx_out
    summary["step_response_horizon_s"] = float(n_step * tau)

    # --- paper 002 ARMA on the torque at constant speed (speed term removed with the batch-LS ex) ----------------
    # paper 002 assumes rigid water hammer (its eq. (2)); with an elastic penstock the first-order model misfits
    if reference is not None and not reference.elastic:
        sa = arma_series if arma_series is not None else series
        m_const_speed = sa.m - six["batch_ls"]["ex"] * sa.x
        try:
            arma = ArmaLeastSquares(water_time_s=reference.water_time_s, sample_time_s=sa.sample_time_s).fit(
                sa.y, m_const_speed)
            arma_out = {"a": arma.a_, "b": arma.b_, "c": arma.c_, "ey": arma.ey_, "e": arma.e_, "eqh": arma.eqh_,
                        "water_time_s": reference.water_time_s, "sample_time_s": sa.sample_time_s,
                        "note": "m - ex_LS x used as the constant-speed torque (eqx x neglected)"}
            if reference_coefficients is not None:
                arma_out["nets"] = {"ey": reference_coefficients.ey,
                                    "e": combined_coefficient(reference_coefficients),
                                    "eqh": reference_coefficients.eqh}
                eff = reference.effective_coefficients()  # the penstock friction seen by the torque
                arma_out["nets_with_friction"] = {"ey": eff[1], "e": combined_coefficient(eff), "eqh": eff[5]}
            summary["arma_paper002"] = arma_out
        except (InputError, NumericalError) as exc:  # e.g. a = -1 or rank-deficient: recorded, the rest stands
            summary["arma_paper002"] = {"error": str(exc)}
    elif reference is not None:
        summary["arma_paper002"] = {"skipped": "paper 002 assumes rigid water hammer; run with the rigid model"}

    if reference is not None:
        # errors relative to the experiment (issue 12): step error as a fraction of the step's peak, simulation-mode
        # error as a fraction of the largest deviation of the measured speed; every recursive estimator is judged,
        # noisy or not (a bound that a 1 %-of-peak noise-free fit passes and a 100 %-off fit fails)
        acceptance = {"batch_ls_within_0.02_of_nets": bool(six.get("max_abs_batch_ls_minus_nets", np.inf)
                                                            <= BATCH_LS_TOLERANCE)}
        for name in JUDGED_ESTIMATORS:
            entry = arx_out[name]
            # the 5 % bound applies when the data come from the penstock model the linear model is (rigid/lumped);
            # for moc / zdomain the step error is reported, not judged (issue 5)
            acceptance[f"{name}_step_response_within_5pct"] = (
                bool(entry["step_error_vs_nets"] <= STEP_RESPONSE_TOLERANCE) if penstock_matches else None)
            acceptance[f"{name}_simulation_mode_within_5pct_of_peak"] = bool(
                entry["simulation_mode_final_theta"]["relative_error"] <= SIMULATION_MODE_TOLERANCE)
        summary["acceptance"] = acceptance
    return {"summary": summary, "histories": histories, "step_responses": steps, "simulation_mode": sim_mode}


# ----------------------------------------------------------------------------------------------------------------
# the whole comparison on the simulator
# ----------------------------------------------------------------------------------------------------------------


def experiment_plant(plant, settings: ExperimentSettings, *, initial_stroke: float, penstock_model: str | None = None):
    """The plant with the open-loop identification scenario (kind ``opening-steps``) and, for rigid/lumped, a
    time step that divides tau (so the opening switches land on the samples)."""
    from simulate.config import ScenarioConfig

    times, levels = settings.opening_schedule()
    increments = np.diff(np.r_[0.0, levels]) * initial_stroke  # cumulative stroke steps (y is relative to a0)
    pen = plant.penstock if penstock_model is None else replace(plant.penstock, model=penstock_model)
    solver = plant.solver
    tau = settings.sample_time_s
    if pen.model != "moc":
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
        Overrides the plant's nets (as in :func:`simulate.engine.run_simulation`).
    exact : Characteristics, optional
        The exact turbine behind a synthetic chart (e.g. :class:`hillchart.synthetic.SyntheticFrancis`): its six
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
    from simulate.config import load_characteristics
    from simulate.engine import initial_state, run_simulation

    settings = settings or ExperimentSettings()
    chars = load_characteristics(plant.turbine, plant.base_dir) if characteristics is None else characteristics
    if initial_opening is not None:
        gov = plant.governor
        if isinstance(initial_opening, bool) or not isinstance(initial_opening, (int, float)) or not (
                gov.stroke_min < initial_opening <= gov.stroke_max):
            raise InputError(f"initial_opening must be a stroke fraction in (governor.stroke_min, "
                             f"governor.stroke_max] = ({gov.stroke_min}, {gov.stroke_max}], got {initial_opening!r}")
        stroke0 = float(initial_opening)
    elif plant.scenario.kind == "frequency-steps":
        raise InputError("identification needs a loaded operating point: the plant's scenario is frequency-steps "
                         "(no load); give initial_opening or use a scenario with initial_power_mw")
    else:
        stroke0 = initial_state(plant, chars).stroke
    run_plant = experiment_plant(plant, settings, initial_stroke=stroke0, penstock_model=penstock_model)
    result = run_simulation(run_plant, chars)
    steady = initial_state(run_plant, chars)
    coeffs, linear = linear_reference(run_plant, chars, steady)
    exact_coeffs = six_coefficients(exact, n11=coeffs.n11_rpm, opening=coeffs.opening) if exact is not None else None
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
    parts = identify_series(series, settings, reference=linear, reference_coefficients=coeffs,
                            exact_coefficients=exact_coeffs, arma_series=arma_series,
                            penstock_matches=run_plant.penstock.model in ("rigid", "lumped"))
    summary = parts["summary"]
    # the nonlinear simulator's own first opening step (noise-free) against the nets' linear prediction
    if settings.step_amplitude > 0:
        times, levels = settings.opening_schedule()
        k_step = int(round(times[0] / settings.sample_time_s))
        n_hold = int(round((times[1] - times[0]) / settings.sample_time_s))
        simulated = clean.x[k_step: k_step + n_hold + 1] / levels[0]
        predicted = linear.step_response(settings.sample_time_s, n_hold)[:, 0]
        summary["simulated_step_vs_nets"] = {
            "max_error_frac_of_peak": float(np.max(np.abs(simulated - predicted)) / np.max(np.abs(predicted))),
            "final_value_simulated": float(simulated[-1]), "final_value_nets": float(predicted[-1]),
            "duration_s": float(n_hold * settings.sample_time_s)}
        parts["step_responses"]["simulated_first_step"] = np.r_[simulated, np.full(
            max(0, parts["step_responses"]["time_s"].size - simulated.size), np.nan)][
            : parts["step_responses"]["time_s"].size]
        # ARX order: the lumped/rigid models are order 3/2; MOC has more modes. Batch LS (lstsq) per order, step
        # response against the nets' ZOH model and against the simulator's own first step
        nets_step = parts["step_responses"]["nets_zoh"]
        sim_step = parts["step_responses"]["simulated_first_step"]
        ok = np.isfinite(sim_step)
        sweep = []
        for order in range(2, 7):
            phi, target = arx_regressors(series.x, series.y, n_a=order, n_b=order, input_delay=0)
            theta = np.linalg.lstsq(phi, target, rcond=None)[0]
            step = ArxModel.from_theta(theta, n_a=order, n_b=order).step_response(nets_step.size - 1)
            if not np.all(np.isfinite(step)) or np.max(np.abs(step)) > 1e6:
                sweep.append({"order": order, "unstable": True})
                continue
            sweep.append({"order": order,
                          "step_error_vs_nets": float(np.max(np.abs(step - nets_step)) / np.max(np.abs(nets_step))),
                          "step_error_vs_simulated_step": float(np.max(np.abs(step[ok] - sim_step[ok]))
                                                                / np.max(np.abs(sim_step[ok])))})
        summary["arx_order_sweep"] = sweep
    summary = {
        "source": "simulation",
        "penstock_model": run_plant.penstock.model,
        "linear_model": "elastic (lumped, eqs. 24-30)" if linear.elastic else "inelastic (rigid, eqs. 10-12)",
        "operating_point": {"speed_rpm": steady.speed_rpm, "head_m": steady.head_m, "flow_m3_s": steady.flow_m3_s,
                            "torque_nm": steady.torque_nm, "stroke": steady.stroke,
                            "opening_chart": steady.opening_chart, "n11_rpm": coeffs.n11_rpm,
                            "q11_m3_s": coeffs.q11_m3_s, "m11_nm": coeffs.m11_nm},
        "linear_parameters": {"water_time_s": linear.water_time_s, "inertia_time_s": linear.inertia_time_s,
                              "self_regulation": linear.self_regulation, "wave_time_s": linear.wave_time_s,
                              "alpha": linear.alpha, "friction_slope": linear.friction_slope,
                              "eigenvalues": [complex(v) for v in linear.state_space().eigenvalues()]},
        "experiment": asdict(settings),
        "simulation": {"dt_s": run_plant.time_step_s, "t_end_s": float(result.time_s[-1]),
                       "wall_time_s": float(result.wall_time_s), "mean_iterations": float(
                           np.mean(result.iterations[1:]))},
    } | summary
    return IdentificationReport(summary=summary, series=series, histories=parts["histories"],
                                step_responses=parts["step_responses"], simulation_mode=parts["simulation_mode"],
                                simulation=result)


def identify_measured(series: RelativeSeries, settings: ExperimentSettings, *, plant=None, characteristics=None,
                      exact=None, arma_series: RelativeSeries | None = None) -> IdentificationReport:
    """Identification on a measured series; with ``plant`` the nets' linear model at the series' operating point
    is the reference (the opening column must then be the stroke fraction)."""
    reference = coeffs = exact_coeffs = None
    summary_head: dict = {"source": "measured"}
    if plant is not None:
        from types import SimpleNamespace

        from simulate.config import load_characteristics

        chars = load_characteristics(plant.turbine, plant.base_dir) if characteristics is None else characteristics
        op = series.operating_point
        steady = SimpleNamespace(speed_rpm=op.speed_rpm, head_m=op.head_m, flow_m3_s=op.flow_m3_s,
                                 torque_nm=op.torque_nm, opening_chart=op.opening * plant.turbine.opening_max)
        coeffs, reference = linear_reference(plant, chars, steady)
        if exact is not None:
            exact_coeffs = six_coefficients(exact, n11=coeffs.n11_rpm, opening=coeffs.opening)
        summary_head["penstock_model"] = plant.penstock.model
    parts = identify_series(series, settings, reference=reference, reference_coefficients=coeffs,
                            exact_coefficients=exact_coeffs, arma_series=arma_series,
                            penstock_matches=plant is not None and plant.penstock.model in ("rigid", "lumped"))
    summary = summary_head | {"operating_point": asdict(series.operating_point),
                              "experiment": asdict(settings)} | parts["summary"]
    return IdentificationReport(summary=summary, series=series, histories=parts["histories"],
                                step_responses=parts["step_responses"], simulation_mode=parts["simulation_mode"])


# ----------------------------------------------------------------------------------------------------------------
# figures
# ----------------------------------------------------------------------------------------------------------------


def plot_report(report: IdentificationReport, out_dir) -> dict[str, Path]:
    """The report's figures (PNG) in ``out_dir``: series, six coefficients, step responses, theta convergence,
    simulation mode."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    paths = {}
    s = report.series
    summ = report.summary

    fig, axes = plt.subplots(5, 1, sharex=True, figsize=(9, 9))
    for ax, (name, values) in zip(axes, (("y (opening)", s.y), ("x (speed)", s.x), ("h (head)", s.h),
                                         ("m (torque)", s.m), ("q (flow)", s.q))):
        ax.plot(s.time_s, 100 * values, lw=0.9)
        ax.set_ylabel(f"{name}, %")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(f"identification data (relative to O), tau = {s.sample_time_s} s")
    fig.tight_layout()
    paths["series_png"] = out / "series.png"
    fig.savefig(paths["series_png"], dpi=100)
    plt.close(fig)

    six = summ["six_coefficients"]
    fig, ax = plt.subplots(figsize=(8, 4))
    groups = [k for k in ("exact", "nets", "batch_ls") if k in six]
    width = 0.8 / len(groups)
    pos = np.arange(6)
    for i, g in enumerate(groups):
        ax.bar(pos + (i - (len(groups) - 1) / 2) * width, [six[g][k] for k in COEFFICIENT_NAMES], width,
               label={"exact": "exact turbine", "nets": "nets (analytic)", "batch_ls": "batch LS (eqs. 69-70)"}[g])
    ax.set_xticks(pos, COEFFICIENT_NAMES)
    ax.axhline(0, color="k", lw=0.5)
    ax.legend()
    ax.set_title("six coefficients")
    fig.tight_layout()
    paths["six_png"] = out / "six_coefficients.png"
    fig.savefig(paths["six_png"], dpi=100)
    plt.close(fig)

    steps = report.step_responses
    if len(steps) > 1:
        fig, ax = plt.subplots(figsize=(8, 4.5))
        for label, values in steps.items():
            if label == "time_s":
                continue
            ax.plot(steps["time_s"], values, lw=2.4 if label == "nets_zoh" else 1.2,
                    ls="-" if label == "nets_zoh" else "--", label=label)
        ax.set_xlabel("time (s)")
        ax.set_ylabel("x per unit opening step")
        ax.grid(alpha=0.3)
        ax.legend()
        ax.set_title("speed step response: ZOH of the nets' linear plant vs identified ARX")
        fig.tight_layout()
        paths["step_png"] = out / "step_response.png"
        fig.savefig(paths["step_png"], dpi=100)
        plt.close(fig)

    hist = report.histories
    if hist:
        names = list(hist)
        p = hist[names[0]].shape[1]
        fig, axes = plt.subplots(p, 1, sharex=True, figsize=(9, 1.6 * p + 1))
        k0 = report.simulation_mode.get("_k0", 0)
        t = s.time_s[k0 + 1: k0 + 1 + hist[names[0]].shape[0]]
        ref = summ["arx"].get("nets_zoh", {}).get("theta")
        for j, ax in enumerate(np.atleast_1d(axes)):
            for name in names:
                ax.plot(t, hist[name][:, j], lw=1.0, label=name)
            if ref is not None and len(ref) == p:
                ax.axhline(ref[j], color="k", ls=":", lw=1.2, label="nets ZOH")
            span = np.ptp([h[:, j][-len(t) // 2:] for h in hist.values()]) if len(t) > 4 else 1.0
            centre = ref[j] if ref is not None and len(ref) == p else np.median(hist[names[0]][:, j])
            lim = max(0.5 * abs(centre), 2 * span, 1e-4)
            ax.set_ylim(centre - lim, centre + lim)
            ax.set_ylabel(f"theta[{j}]")
            ax.grid(alpha=0.3)
            quiet = summ.get("experiment", {}).get("quiet_s", 0.0)
            if quiet and len(t):
                ax.axvspan(t[-1] - quiet, t[-1], color="0.9", zorder=0)
        np.atleast_1d(axes)[0].legend(fontsize=7, ncol=4)
        np.atleast_1d(axes)[-1].set_xlabel("time (s)")
        fig.suptitle("theta_hat(k): RLS, RLS with forgetting, dead-zone RLS (noise level "
                     f"{summ.get('experiment', {}).get('noise_level', 0)}; grey: quiet tail, constant opening)")
        fig.tight_layout()
        paths["theta_png"] = out / "theta_convergence.png"
        fig.savefig(paths["theta_png"], dpi=100)
        plt.close(fig)

    sim = {k: v for k, v in report.simulation_mode.items() if k != "_k0"}
    if sim:
        fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(9, 6))
        ax1.plot(s.time_s, 100 * s.x, color="k", lw=1.6, label="x (data)")
        for name, xh in sim.items():
            ax1.plot(s.time_s, 100 * xh, lw=1.0, ls="--", label=f"x_hat {name}")
            ax2.plot(s.time_s, 100 * (s.x - xh), lw=1.0, label=name)
        ax1.set_ylabel("speed x, %")
        ax2.set_ylabel("e_speed = x - x_hat, %")
        ax2.set_xlabel("time (s)")
        for ax in (ax1, ax2):
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
        fig.suptitle("simulation mode (paper 000 eqs. 62-64), final theta")
        fig.tight_layout()
        paths["simulation_mode_png"] = out / "simulation_mode.png"
        fig.savefig(paths["simulation_mode_png"], dpi=100)
        plt.close(fig)
    return paths


# ----------------------------------------------------------------------------------------------------------------
# tables
# ----------------------------------------------------------------------------------------------------------------


def _fmt(value, digits=4, none="-") -> str:
    if value is None:
        return none
    if isinstance(value, bool):
        return "PASS" if value else "FAIL"
    if isinstance(value, float) and not math.isfinite(value):
        return "nan"
    return f"{value:.{digits}f}" if abs(value) >= 1e-3 or value == 0 else f"{value:.3e}"


def markdown_tables(summary: dict) -> str:
    """The comparison as markdown tables (six coefficients, ARX theta side by side, responses, acceptance)."""
    lines = []
    six = summary["six_coefficients"]
    cols = [k for k in ("exact", "nets", "batch_ls") if k in six]
    head = {"exact": "exact turbine", "nets": "nets (analytic)", "batch_ls": "batch LS (eqs. 69-70)"}
    extra = "nets" in six
    lines.append("| coefficient | " + " | ".join(head[c] for c in cols) + (" | batch LS - nets |" if extra else " |"))
    lines.append("|---" * (len(cols) + 1 + int(extra)) + "|")
    for k in COEFFICIENT_NAMES:
        row = [_fmt(six[c][k]) for c in cols]
        if extra:
            row.append(_fmt(six["batch_ls_minus_nets"][k]))
        lines.append(f"| {k} | " + " | ".join(row) + " |")
    lines.append("")
    arx = summary["arx"]
    names = [n for n in ("nets_zoh", "rls", "rls_forgetting", "dead_zone_rls") if n in arx]
    p = len(arx["rls"]["theta"])
    st = summary["arx_structure"]
    labels = [f"a{i + 1}" for i in range(st["n_a"])] + [f"b{j + 1}" for j in range(st["n_b"])]
    title = {"nets_zoh": "ZOH of nets' model", "rls": "RLS", "rls_forgetting": f"RLS, lambda = "
             f"{arx['forgetting_factor']}", "dead_zone_rls": f"dead-zone RLS, eps0 = {arx['dead_zone_eps0']:.2g}"}
    lines.append("| theta | " + " | ".join(title[n] for n in names) + " |")
    lines.append("|---" * (len(names) + 1) + "|")
    for j in range(p):
        lines.append(f"| {labels[j]} | " + " | ".join(_fmt(arx[n]["theta"][j]) for n in names) + " |")
    lines.append("")
    lines.append("| estimator | step response error vs nets (of peak) | simulation-mode max abs speed error (final "
                 "theta) | same, on-line theta(k) | theta spread in the quiet tail |")
    lines.append("|---|---|---|---|---|")
    for n in ("rls", "rls_forgetting", "dead_zone_rls", "paper_eq53_rls", "zoh_rls"):
        if n not in arx:
            continue
        e = arx[n]
        online = e["simulation_mode_online"]
        lines.append(f"| {n} | {_fmt(e.get('step_error_vs_nets'))} | "
                     f"{_fmt(e['simulation_mode_final_theta']['max_abs_error'], 5)} | "
                     f"{_fmt(online.get('max_abs_error'), 5) if 'max_abs_error' in online else 'diverged'} | "
                     f"{_fmt(e['theta_spread_quiet_tail'])} |")
    if "simulated_step_vs_nets" in summary:
        s = summary["simulated_step_vs_nets"]
        lines.append("")
        lines.append(f"Nonlinear simulator's first +{summary['experiment']['step_amplitude']:.0%} step vs the nets' "
                     f"linear prediction: max difference {_fmt(s['max_error_frac_of_peak'])} of the peak "
                     f"(final value {_fmt(s['final_value_simulated'])} vs {_fmt(s['final_value_nets'])} per unit "
                     "step).")
    if "arx_order_sweep" in summary:
        lines.append("")
        lines.append("| ARX order (batch LS, ZOH structure) | step error vs nets | step error vs the simulator's own "
                     "first step |")
        lines.append("|---|---|---|")
        for row in summary["arx_order_sweep"]:
            if row.get("unstable"):
                lines.append(f"| {row['order']} | unstable | unstable |")
            else:
                lines.append(f"| {row['order']} | {_fmt(row['step_error_vs_nets'])} | "
                             f"{_fmt(row['step_error_vs_simulated_step'])} |")
    if "arma_paper002" in summary and "ey" in summary["arma_paper002"]:
        a = summary["arma_paper002"]
        nets = a.get("nets", {})
        eff = a.get("nets_with_friction", {})
        lines.append("")
        lines.append(f"| paper 002 (Dt = {a['sample_time_s']} s) | ARMA LS (eqs. 9-12, 8) | nets | nets with the "
                     "penstock friction folded in |")
        lines.append("|---|---|---|---|")
        for k in ("ey", "e", "eqh"):
            lines.append(f"| {k} | {_fmt(a[k])} | {_fmt(nets.get(k))} | {_fmt(eff.get(k))} |")
    if "acceptance" in summary:
        lines.append("")
        lines.append("| acceptance check | result |")
        lines.append("|---|---|")
        for k, v in summary["acceptance"].items():
            lines.append(f"| {k} | {_fmt(v, none='reported only (penstock model is not the linear one)')} |")
        if "acceptance_note" in summary:
            lines.append("")
            lines.append(f"Note: {summary['acceptance_note']}.")
    return "\n".join(lines) + "\n"
