"""Typed records of an identification: what :func:`simulate.identification.compare.compare_identification` and
:func:`simulate.identification.compare.identify_measured` found.

Every record is a frozen dataclass; :func:`to_json_dict` is the one function that turns a record into the JSON of
``identification.json`` (the field names are the file's keys). A field marked ``optional`` is left out of the JSON
when it is None (a section that does not apply, e.g. the nets' coefficients for a measured series without a plant);
other None values are written as ``null`` (e.g. a check that is reported, not judged).

Examples
--------
>>> check = AcceptanceCheck(name="batch_ls_within_0.02_of_nets", value=0.0039, bound=0.02, passed=True)
>>> to_json_dict(check)
{'name': 'batch_ls_within_0.02_of_nets', 'value': 0.0039, 'bound': 0.02, 'passed': True, 'reason': ''}
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, fields, is_dataclass

import numpy as np

from simulate.identification.experiment import ExperimentSettings
from simulate.identification.measured import OperatingPoint
from simulate.results.result import json_default

#: Acceptance bounds of the identification (checked and reported, never silently relaxed).
BATCH_LS_TOLERANCE = 0.02  # absolute, each of the six coefficients, noise-free small signal
STEP_RESPONSE_TOLERANCE = 0.05  # max |step_rls - step_nets| / max |step_nets|
SIMULATION_MODE_TOLERANCE = 0.05  # max |x - x_hat| / max |x|: a fraction of the largest measured speed deviation
#: Recursive estimators the acceptance judges (each on step response and simulation mode).
JUDGED_ESTIMATORS = ("rls", "rls_forgetting", "dead_zone_rls")


def optional(default=None):
    """A field left out of the JSON when it is None (a section that does not apply)."""
    return field(default=default, metadata={"optional": True})


def _plain(value):
    if is_dataclass(value) and not isinstance(value, type):
        return {f.name: _plain(getattr(value, f.name)) for f in fields(value)
                if not (f.metadata.get("optional") and getattr(value, f.name) is None)}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    return value


def to_json_dict(record) -> dict:
    """The JSON form of a record: :func:`dataclasses.asdict` (without the optional fields that are None), numpy
    values and complex numbers converted by :func:`simulate.results.result.json_default`."""
    return json.loads(json.dumps(_plain(record), default=json_default))


# ----------------------------------------------------------------------------------------------------------------
# six coefficients
# ----------------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CoefficientSet:
    """The six relative coefficients ``m = ex x + ey y + eh h``, ``q = eqx x + eqy y + eqh h`` (paper 000 eqs. 4-5)."""

    ex: float
    ey: float
    eh: float
    eqx: float
    eqy: float
    eqh: float

    @classmethod
    def of(cls, source) -> "CoefficientSet":
        """From any object with the six attributes (e.g. :class:`hillchart.linearize.SixCoefficients`)."""
        return cls(**{f.name: float(getattr(source, f.name)) for f in fields(cls)})

    def values(self) -> tuple[float, ...]:
        """``(ex, ey, eh, eqx, eqy, eqh)``."""
        return tuple(getattr(self, f.name) for f in fields(self))

    def minus(self, other: "CoefficientSet") -> "CoefficientSet":
        return CoefficientSet(*(a - b for a, b in zip(self.values(), other.values())))

    def max_abs_difference(self, other: "CoefficientSet") -> float:
        return max(abs(a - b) for a, b in zip(self.values(), other.values()))


@dataclass(frozen=True)
class ResidualRms:
    """RMS of the batch-LS residuals of the torque and flow equations (relative units)."""

    m: float
    q: float


@dataclass(frozen=True)
class SixCoefficientResult:
    """Batch least squares of the six coefficients (paper 000 eqs. 69-70) against the nets and the exact turbine."""

    batch_ls: CoefficientSet
    condition_number: float
    residual_rms: ResidualRms
    nets: CoefficientSet | None = optional()
    batch_ls_minus_nets: CoefficientSet | None = optional()
    max_abs_batch_ls_minus_nets: float | None = optional()
    exact: CoefficientSet | None = optional()
    max_abs_nets_minus_exact: float | None = optional()
    max_abs_batch_ls_minus_exact: float | None = optional()


# ----------------------------------------------------------------------------------------------------------------
# ARX speed model
# ----------------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ArxStructure:
    """``x(k+1) = sum_i a_i x(k+1-i) + sum_j b_j y(k+1-j-input_delay)``, i = 1..n_a, j = 1..n_b."""

    n_a: int
    n_b: int
    input_delay: int


@dataclass(frozen=True)
class SimulationModeError:
    """Simulation-mode speed error of an ARX model (paper 000 eqs. 62-64): ``max_abs_error`` = max |x - x_hat| in
    per-unit speed, ``peak_abs_output`` = max |x| of the experiment, ``relative_error`` = their ratio."""

    max_abs_error: float
    peak_abs_output: float
    relative_error: float

    @classmethod
    def of(cls, output) -> "SimulationModeError":
        """From a :class:`simulate.identification.estimators.SimulationModeResult`."""
        return cls(max_abs_error=float(output.max_abs_error), peak_abs_output=float(output.peak_abs_output),
                   relative_error=output.relative_error)


@dataclass(frozen=True)
class DivergedSimulationMode:
    """The simulation-mode output that diverged (a result, recorded with the error's message)."""

    error: str


@dataclass(frozen=True)
class NetsZohArx:
    """The ARX model the zero-order hold of the nets' linear plant implies (paper 000 eqs. 32-36)."""

    a: tuple[float, ...]
    b: tuple[float, ...]
    input_delay: int
    sample_time_s: float
    theta: tuple[float, ...]

    @classmethod
    def of(cls, model) -> "NetsZohArx":
        """From a :class:`simulate.linear.models.ArxModel`."""
        return cls(a=tuple(float(v) for v in model.a), b=tuple(float(v) for v in model.b),
                   input_delay=int(model.input_delay), sample_time_s=float(model.sample_time_s),
                   theta=tuple(float(v) for v in model.theta))


@dataclass(frozen=True)
class ArxEstimate:
    """One recursive estimator's ARX model.

    Attributes
    ----------
    theta : tuple of float
        Final estimate, a's then b's.
    updates : int
        Number of parameter updates (the dead zone skips some).
    simulation_mode_final_theta, simulation_mode_online
        Simulation-mode error with the final theta and with the on-line theta(k).
    theta_spread_quiet_tail : float or None
        max |theta(k) - theta(k_quiet)| over the quiet tail; None when the series has no quiet tail.
    step_error_vs_nets : float or None
        max |step_ARX - step_nets| / max |step_nets| (needs the nets' reference).
    max_pole_modulus, stable
        Largest |pole| and whether it is < 1 (set by the review of ``hillsim identify``).
    """

    theta: tuple[float, ...]
    updates: int
    n_a: int
    n_b: int
    input_delay: int
    simulation_mode_final_theta: SimulationModeError
    simulation_mode_online: SimulationModeError | DivergedSimulationMode
    theta_spread_quiet_tail: float | None
    step_error_vs_nets: float | None = optional()
    max_pole_modulus: float | None = optional()
    stable: bool | None = optional()

    def pole_modulus(self) -> float:
        """Largest |pole| of ``x(k+1) = sum a_i x(k+1-i) + ...``: the roots of z^n - a1 z^(n-1) - ... - an (inf
        when a coefficient is not finite). The model is unstable when it is >= 1."""
        a = np.asarray(self.theta[: self.n_a], dtype=float)
        if not np.all(np.isfinite(a)):
            return float("inf")
        roots = np.roots(np.r_[1.0, -a])
        return float(np.max(np.abs(roots))) if roots.size else 0.0


@dataclass(frozen=True, kw_only=True)
class ArxResults:
    """The ARX speed model (paper 000 eq. 53) by RLS (eqs. 57-59), RLS with forgetting and dead-zone RLS (paper 001
    eqs. 5-8), in the chosen structure; plain RLS also in the other structure (``paper_eq53_rls`` or ``zoh_rls``)."""

    dead_zone_eps0: float
    forgetting_factor: float
    rls_p0: float
    nets_zoh: NetsZohArx | None = optional()
    rls: ArxEstimate
    rls_forgetting: ArxEstimate
    dead_zone_rls: ArxEstimate
    paper_eq53_rls: ArxEstimate | None = optional()
    zoh_rls: ArxEstimate | None = optional()

    def estimates(self) -> dict[str, ArxEstimate]:
        """``{name: estimate}`` of every identified model, in the report's order."""
        names = ("rls", "rls_forgetting", "dead_zone_rls", "paper_eq53_rls", "zoh_rls")
        return {name: getattr(self, name) for name in names if getattr(self, name) is not None}


@dataclass(frozen=True)
class ArxOrderRow:
    """One row of the ARX order sweep (batch LS, ZOH structure): step errors against the nets' ZOH model and the
    simulator's own first step (None for an unstable model)."""

    order: int
    unstable: bool
    step_error_vs_nets: float | None
    step_error_vs_simulated_step: float | None


@dataclass(frozen=True)
class SimulatedStepComparison:
    """The simulator's own first opening step (noise-free, per unit step) against the nets' linear prediction."""

    max_error_frac_of_peak: float
    final_value_simulated: float
    final_value_nets: float
    duration_s: float


# ----------------------------------------------------------------------------------------------------------------
# paper 002
# ----------------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ArmaCoefficients:
    """Paper 002's three numbers: ``ey``, ``e = eqy eh / ey - eqh`` (its eq. 8) and ``eqh``."""

    ey: float
    e: float
    eqh: float


@dataclass(frozen=True)
class ArmaFit:
    """Paper 002's ARMA least squares (eqs. 9-12) on the constant-speed torque, mapped back by eq. 8."""

    a: float
    b: float
    c: float
    ey: float
    e: float
    eqh: float
    water_time_s: float
    sample_time_s: float
    note: str
    nets: ArmaCoefficients | None = optional()
    nets_with_friction: ArmaCoefficients | None = optional()


@dataclass(frozen=True)
class ArmaError:
    """The ARMA fit failed (e.g. rank-deficient); the rest of the identification stands."""

    error: str


@dataclass(frozen=True)
class ArmaSkipped:
    """The ARMA fit does not apply (paper 002 assumes rigid water hammer)."""

    skipped: str


# ----------------------------------------------------------------------------------------------------------------
# acceptance
# ----------------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class AcceptanceCheck:
    """One acceptance check of the identification: ``value`` against ``bound``; ``passed`` None = reported, not
    judged, and ``reason`` says why."""

    name: str
    value: float
    bound: float
    passed: bool | None
    reason: str = ""


@dataclass(frozen=True)
class Acceptance:
    """The checks against the nets' linear model: batch LS within 0.02, and for each recursive estimator
    the step-response error as a fraction of the step's peak and the simulation-mode error as a fraction of the
    largest deviation of the measured speed, both within 5 % (bounds a bad identification fails)."""

    batch_ls: AcceptanceCheck
    rls_step_response: AcceptanceCheck
    rls_simulation_mode: AcceptanceCheck
    rls_forgetting_step_response: AcceptanceCheck
    rls_forgetting_simulation_mode: AcceptanceCheck
    dead_zone_rls_step_response: AcceptanceCheck
    dead_zone_rls_simulation_mode: AcceptanceCheck

    def checks(self) -> tuple[AcceptanceCheck, ...]:
        return tuple(getattr(self, f.name) for f in fields(self))


# ----------------------------------------------------------------------------------------------------------------
# the summary
# ----------------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ExperimentOperatingPoint:
    """The verified steady state O of the simulated experiment and its chart coordinates."""

    speed_rpm: float
    head_m: float
    flow_m3_s: float
    torque_nm: float
    stroke: float
    opening_chart: float
    n11_rpm: float
    q11_m3_s: float
    m11_nm: float


@dataclass(frozen=True)
class LinearParameters:
    """The nets' linear plant (paper 000 eqs. 10-12 or 24-30) and the eigenvalues of its A (1/s)."""

    water_time_s: float
    inertia_time_s: float
    self_regulation: float
    wave_time_s: float
    alpha: float
    friction_slope: float
    eigenvalues: tuple[complex, ...]


@dataclass(frozen=True)
class SimulationInfo:
    """The nonlinear run of the experiment."""

    dt_s: float
    t_end_s: float
    wall_time_s: float
    mean_iterations: float


@dataclass(frozen=True)
class SeriesIdentification:
    """What the estimators found on one series (the part of :class:`IdentificationSummary` that
    :func:`simulate.identification.compare.identify_series` fills)."""

    sample_time_s: float
    samples: int
    arx_structure: ArxStructure
    peak_abs_x: float
    six_coefficients: SixCoefficientResult
    arx: ArxResults
    step_response_horizon_s: float
    arma_paper002: ArmaFit | ArmaError | ArmaSkipped | None = optional()
    acceptance: Acceptance | None = optional()
    acceptance_note: str | None = optional()


@dataclass(frozen=True, kw_only=True)
class IdentificationSummary:
    """The numbers of an identification (``identification.json``, via :func:`to_json_dict`; fields in the file's
    order).

    ``source`` is ``"simulation"`` or ``"measured"``; ``operating_point`` is an :class:`ExperimentOperatingPoint`
    (simulated) or the measured series' :class:`simulate.identification.measured.OperatingPoint`; ``warnings`` are the
    review's notes (``hillsim identify``).
    """

    source: str
    penstock_model: str | None = optional()
    linear_model: str | None = optional()
    operating_point: ExperimentOperatingPoint | OperatingPoint
    linear_parameters: LinearParameters | None = optional()
    experiment: ExperimentSettings
    simulation: SimulationInfo | None = optional()
    sample_time_s: float
    samples: int
    arx_structure: ArxStructure
    peak_abs_x: float
    six_coefficients: SixCoefficientResult
    arx: ArxResults
    step_response_horizon_s: float
    arma_paper002: ArmaFit | ArmaError | ArmaSkipped | None = optional()
    acceptance: Acceptance | None = optional()
    acceptance_note: str | None = optional()
    simulated_step_vs_nets: SimulatedStepComparison | None = optional()
    arx_order_sweep: tuple[ArxOrderRow, ...] | None = optional()
    warnings: tuple[str, ...] | None = optional()

    @classmethod
    def build(cls, found: SeriesIdentification, **head) -> "IdentificationSummary":
        """The summary from what the estimators found and the run's description (``source``, ...)."""
        return cls(**head, **{f.name: getattr(found, f.name) for f in fields(found)})
