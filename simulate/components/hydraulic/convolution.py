"""Convolution-based unsteady friction (``penstock.friction_model = "convolution"``): Zielke's weighting function in
laminar flow, Vardy and Brown's in smooth-pipe turbulent flow, computed recursively on a sum of exponentials (a
friction model of :mod:`simulate.components.hydraulic.friction`).

The friction slope (head per length, signed with the flow) is the steady one plus the convolution of the past
accelerations of the mean velocity V with a weighting function W of the dimensionless time tau = 4 nu t / D^2
(equations numbered here; nu the kinematic viscosity, D the diameter)::

    (U1)  J = f V|V| / (2 g D) + (16 nu / (g D^2)) integral_0^t W(tau(t - s)) dV/ds ds        Zielke (1968)
    (U2)  W(tau) = sum_k exp(-j_k^2 tau),  j_k the zeros of the Bessel function J_2            laminar (Zielke)
    (U3)  W(tau) = A* exp(-B* tau) / sqrt(tau),  A* = 1 / (2 sqrt(pi)),  B* = Re^kappa / 12.86,
          kappa = log10(15.29 / Re^0.0567)                                        turbulent, smooth pipe (Vardy-Brown)

Both weightings are sums of exponentials: (U2) by its series, whose terms beyond the first :data:`ZIELKE_TERMS`
are spaced pi apart in j and are taken as the integral (1 / pi) integral exp(-x^2 tau) dx; (U3) by Euler's integral
1 / sqrt(tau) = (1 / sqrt(pi)) integral exp(u / 2) exp(-e^u tau) du. With u = ln(rate) both are the integral::

    (U4)  (1 / (2 pi)) integral exp(u / 2) exp(-(e^u + B*) tau) du          (B* = 0 for the laminar series' tail)

taken by the trapezoid rule in u at the step :data:`LOG_RATE_STEP` (an integrand analytic in the strip |Im u| <
pi / 2: the error is of the order exp(-pi^2 / h); at h = 1.5 W is within 0.4 % over the times that matter), which
gives W(tau) = sum_i m_i exp(-n_i tau) (rates from :data:`RATE_SPAN_LOW` B* to :data:`RATE_SPAN_HIGH` / Delta tau,
the part below as one term of rate B*). With the velocity linear in time over each step, the convolution of every
exponential is advanced exactly (Vitkovsky, Stephens, Bergant, Simpson and Lambert 2004)::

    (U5)  y_i^(n+1) = exp(-n_i Delta tau) y_i^n + m_i (1 - exp(-n_i Delta tau)) / (n_i Delta tau) (Q^(n+1) - Q^n)
    (U6)  Delta h_f = a dt J = R Q_j|Q_j| + dx (16 nu / (g D^2 A)) sum_i y_i            (y_i in m^3/s)

at the foot j of each characteristic (node r of reach r for C+, node r + 1 for C-), with one history per node and
side (the weights depend on the reach's diameter; at a node inside a segment one history serves both sides). The
rates the step cannot resolve (n_i Delta tau > 30) forget within one step and are one term of decay 0 whose gain is
the sum of their m_i (1 - exp(-z)) / z: the part of W's singularity inside one step is integrated, not dropped, and
the result converges as the step shrinks (the convolution, not a step-dependent coefficient, sets the damping). In
steady flow every y_i is zero and the loss is the steady one to the last bit. B* is taken at the steady Reynolds
number of each segment (frozen, as Vardy and Brown apply it); below Re = 2000 the laminar (U2). Unlike Brunone's
instantaneous-acceleration form, whose term cancels on a front travelling upstream, the convolution turns the wall
shear behind a closure's front against the old flow: the line packs more, and the first head peak of an
instantaneous closure is slightly higher than with the steady loss (0.7 % of the rise in
``tests/simulate/components/test_convolution_friction.py``, the same at every step).

References: W. Zielke, "Frequency-dependent friction in transient pipe flow", J. Basic Eng. 90(1), 109-115, 1968.
A. E. Vardy, J. M. B. Brown, "Transient turbulent friction in smooth pipe flows", J. Sound Vib. 259(5), 1011-1036,
2003. J. P. Vitkovsky, M. Stephens, A. Bergant, A. R. Simpson, M. F. Lambert, "Efficient and accurate calculation of
Zielke and Vardy-Brown unsteady friction in pipe transients", 9th Int. Conf. on Pressure Surges, BHR, 2004.
A. K. Trikha, "An efficient method for simulating frequency-dependent friction in transient liquid flow", J. Fluids
Eng. 97(1), 97-105, 1975.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from hillchart.constants import G_M_S2
from hillchart.errors import InputError
from simulate.components.contract import ROWS_BY_NODE, StateArray
from simulate.components.hydraulic.friction import WATER_VISCOSITY_M2_S, CompiledFriction, segment_reynolds
from simulate.components.parameters import parameter, validate_parameters

#: Its memory (the last two arrays of its ``arrays``): at each node, as the foot of its downstream reach (C+, side
#: 0) and of its upstream reach (C-, side 1), the terms y_i of (U5) (rows side * terms + i) and their sums (rows =
#: sides). At a node inside a segment both sides have the same weights: side 1's sum is side 0's, its terms unused.
STATES = (StateArray("convolution_terms", "m^3/s", "the exponential terms of the friction convolution at each node, "
                     "per side", ROWS_BY_NODE),
          StateArray("convolution_sums", "m^3/s", "the sum of the terms at each node, per side", ROWS_BY_NODE))
#: None: explicit on the MOC grid, whose step the penstock sets.
TIME_SCALES = ()
#: None: the unsteady term vanishes at a steady state; the linear model of the plant keeps the steady slope only.
LINEAR_COUNTERPART = None
#: The ``[penstock]`` keys of this model (refused under another friction model).
PENSTOCK_KEYS = ("convolution_viscosity_m2_s",)
#: Reynolds number below which the flow is laminar: Zielke's (U2), else Vardy and Brown's (U3).
LAMINAR_REYNOLDS = 2000.0
#: Step of the trapezoid rule in u = ln(rate) of (U4).
LOG_RATE_STEP = 1.5
#: The same for the laminar series' tail, whose midpoint rule starts at a finite u (0.17 % of W at 0.5, 2.2 % at 1.5).
LAMINAR_LOG_RATE_STEP = 0.5
#: The rates of (U4) run from RATE_SPAN_LOW B* (laminar: the tail's first rate) to RATE_SPAN_HIGH / Delta tau. Below,
#: the terms together weigh at most sqrt(RATE_SPAN_LOW) / 3 of W at tau = 1 / B*; above, they are instantaneous
#: within one step and their sum m_i / (n_i Delta tau) misses 1 / sqrt(pi RATE_SPAN_HIGH) of one step's response.
RATE_SPAN_LOW = 1e-6
RATE_SPAN_HIGH = 1e8
#: A term whose rate times the step exceeds this forgets within one step (decay below exp(-30)): such terms are one.
INSTANT_RATE_STEPS = 30.0
#: The laminar series (U2) term by term up to its ZIELKE_TERMS-th zero, then its tail as the integral (U4).
ZIELKE_TERMS = 12


@dataclass(frozen=True)
class ConvolutionConfig:
    """The key of the convolution model (``[penstock]`` key ``convolution_viscosity_m2_s``)."""

    kinematic_viscosity_m2_s: float | None = parameter(
        None, unit="m^2/s", low=1e-7, high=1e-4,
        description="kinematic viscosity of the convolution friction's dimensionless time and Reynolds number "
                    "(convolution friction; default 1e-6, water at 20 C)")

    def __post_init__(self):
        validate_parameters("penstock", self)


def vardy_brown_decay(reynolds: float) -> float:
    """B* of Vardy and Brown's smooth-pipe weighting, eq. (U3) of this module.

    >>> round(vardy_brown_decay(1e5), 1)
    2484.8
    """
    if not (math.isfinite(reynolds) and reynolds >= LAMINAR_REYNOLDS):
        raise InputError(f"Vardy and Brown's weighting is for turbulent flow, Re >= {LAMINAR_REYNOLDS:g}; got "
                         f"{reynolds!r}")
    kappa = math.log10(15.29 / reynolds ** 0.0567)  # eq. (U3)
    return reynolds ** kappa / 12.86  # eq. (U3)


def weighting_terms(reynolds: float, step_tau: float) -> tuple[np.ndarray, np.ndarray]:
    """W(tau) = sum_i m_i exp(-n_i tau) for a grid of dimensionless step ``step_tau``: (weights, rates), eqs.
    (U2)-(U4): Zielke's below :data:`LAMINAR_REYNOLDS`, Vardy and Brown's above.

    The trapezoid rule of (U4) runs over u = ln(rate) from :data:`RATE_SPAN_LOW` B* to :data:`RATE_SPAN_HIGH` /
    ``step_tau``; the part below (rates small beside B*, whose exponentials all decay as exp(-B* tau)) is one term
    of weight (1 / pi) exp(u_low / 2) at the rate B* (turbulent). The laminar tail starts at a finite u, where the
    midpoint rule is used."""
    if not (math.isfinite(step_tau) and step_tau > 0.0):
        raise InputError(f"the dimensionless time step 4 nu dt / D^2 must be > 0, got {step_tau!r}")
    u_high = math.log(RATE_SPAN_HIGH / step_tau)
    if reynolds < LAMINAR_REYNOLDS:
        from scipy.special import jn_zeros

        zeros = jn_zeros(2, ZIELKE_TERMS + 1)
        x_tail = 0.5 * (zeros[-2] + zeros[-1])  # the tail's density 1/pi starts half a spacing past the last term
        u_low = 2.0 * math.log(x_tail)
        count = max(int(math.ceil((u_high - u_low) / LAMINAR_LOG_RATE_STEP)), 1)
        h = (u_high - u_low) / count
        u = u_low + h * (np.arange(count) + 0.5)
        weights = h * np.exp(u / 2.0) / (2.0 * math.pi)  # eq. (U4), B* = 0
        return np.concatenate([np.ones(ZIELKE_TERMS), weights]), np.concatenate([zeros[:-1] ** 2, np.exp(u)])  # (U2)
    decay = vardy_brown_decay(reynolds)
    u_low = math.log(RATE_SPAN_LOW * decay)
    u_high = max(u_high, u_low + LOG_RATE_STEP)
    count = int(math.ceil((u_high - u_low) / LOG_RATE_STEP))
    u = np.linspace(u_low, u_high, count + 1)
    h = (u_high - u_low) / count
    weights = h * np.exp(u / 2.0) / (2.0 * math.pi)  # eq. (U4), the trapezoid rule
    weights[0] = 0.5 * weights[0] + math.exp(u_low / 2.0) / math.pi  # and the integral below u_low
    weights[-1] *= 0.5
    return weights, np.exp(u) + decay  # eq. (U3)


def weighting(reynolds: float, tau) -> np.ndarray:
    """W(tau) of eq. (U2) (laminar; its series to 2000 terms, for checking) or (U3) (turbulent), closed form."""
    tau = np.asarray(tau, dtype=float)
    if reynolds < LAMINAR_REYNOLDS:
        from scipy.special import jn_zeros

        rates = jn_zeros(2, 2000) ** 2
        return np.exp(-np.multiply.outer(tau, rates)).sum(axis=-1)  # eq. (U2)
    return np.exp(-vardy_brown_decay(reynolds) * tau) / (2.0 * math.sqrt(math.pi) * np.sqrt(tau))  # eq. (U3)


@numba.njit(cache=True)
def convolution_reach_loss(friction, flows, reach, node):
    """Delta h_f of reach ``reach`` on the characteristic whose foot is node ``node`` (``reach``: C+, ``reach + 1``:
    C-), eq. (U6) of this module, m.

    ``friction`` = (R per reach (s^2/m^5), dx 16 nu / (g D^2 A) per reach (s/m^2), the decays exp(-n_i Delta tau)
    and the gains of eq. (U5) (shape (2, nodes, terms)), whether a node's side 1 shares side 0's weights, the terms
    (shape (2 terms, nodes)) and their sums (shape (2, nodes)))."""
    steady, scale, sums = friction[0], friction[1], friction[6]
    q = flows[node]
    return steady[reach] * q * abs(q) + scale[reach] * sums[node - reach, node]


@numba.njit(cache=True)
def convolution_advance(friction, flows, new_flows):
    """Advance every node's terms by its flow change over the step, eq. (U5), and keep their sums."""
    decay, gain, shared, terms, sums = friction[2], friction[3], friction[4], friction[5], friction[6]
    count = decay.shape[2]
    nodes = sums.shape[1]
    for j in range(nodes):
        change = new_flows[j] - flows[j]
        for side in range(2):
            if (side == 0 and j == nodes - 1) or (side == 1 and j == 0):
                continue  # no reach on that side
            if side == 1 and shared[j]:
                sums[1, j] = sums[0, j]
                continue
            s = 0.0
            for i in range(count):
                y = decay[side, j, i] * terms[side * count + i, j] + gain[side, j, i] * change  # eq. (U5)
                terms[side * count + i, j] = y
                s += y
            sums[side, j] = s


def step_terms(weights, rates, step_tau: float) -> tuple[np.ndarray, np.ndarray]:
    """Decays exp(-n_i Delta tau) and gains m_i (1 - exp(-n_i Delta tau)) / (n_i Delta tau) of eq. (U5); the terms
    that forget within one step (n_i Delta tau > :data:`INSTANT_RATE_STEPS`, decay below exp(-30)) as one term of
    decay 0 and their gains' sum."""
    z = np.asarray(rates, float) * step_tau
    gain = np.asarray(weights, float) * -np.expm1(-z) / z  # eq. (U5)
    slow = z <= INSTANT_RATE_STEPS
    return np.append(np.exp(-z[slow]), 0.0), np.append(gain[slow], gain[~slow].sum())


def build_convolution_friction(penstock, grid, flow_m3_s: float) -> CompiledFriction:
    """The convolution model on ``grid``, started from steady flow (no past acceleration): at each node one history
    per side, the weights of the reach on that side (at a node inside a segment one history serves both)."""
    nu = WATER_VISCOSITY_M2_S if penstock.convolution_viscosity_m2_s is None else penstock.convolution_viscosity_m2_s
    reynolds = segment_reynolds(penstock, flow_m3_s, nu)
    reaches = grid.impedance_s_m2.size
    scale = np.zeros(reaches)
    per_reach = []
    r = 0
    for seg, count, speed, re in zip(penstock.segments, grid.reaches_per_segment, grid.wave_speed_used_m_s, reynolds):
        dx = seg.length_m / count
        step_tau = 4.0 * nu * (dx / speed) / seg.diameter_m ** 2
        terms = step_terms(*weighting_terms(re, step_tau), step_tau)
        scale[r:r + count] = dx * 16.0 * nu / (G_M_S2 * seg.diameter_m ** 2 * seg.area_m2)  # eq. (U6)
        per_reach += [terms] * count
        r += count
    size = max(d.size for d, _ in per_reach)
    decay, gain = np.zeros((2, reaches + 1, size)), np.zeros((2, reaches + 1, size))
    for r, (d, g) in enumerate(per_reach):  # a shorter list's unused terms: decay 0, gain 0 (always 0)
        decay[0, r, :d.size], gain[0, r, :g.size] = d, g  # node r, the foot of reach r's C+ line
        decay[1, r + 1, :d.size], gain[1, r + 1, :g.size] = d, g  # node r + 1, the foot of its C- line
    shared = np.zeros(reaches + 1, dtype=np.bool_)
    for j in range(1, reaches):
        shared[j] = per_reach[j - 1] is per_reach[j]
    laminar = [re < LAMINAR_REYNOLDS for re in reynolds]
    return CompiledFriction("convolution", convolution_reach_loss, convolution_advance,
                            (grid.friction_s2_m5, scale, decay, gain, shared, np.zeros((2 * size, reaches + 1)),
                             np.zeros((2, reaches + 1))),
                            summary={"convolution_terms": size, "convolution_reynolds_min": min(reynolds),
                                     "convolution_weighting": "zielke" if all(laminar) else
                                     ("vardy-brown" if not any(laminar) else "zielke and vardy-brown")})


__all__ = ["PENSTOCK_KEYS", "ConvolutionConfig", "vardy_brown_decay", "weighting_terms", "weighting",
           "convolution_reach_loss", "convolution_advance", "step_terms",
           "build_convolution_friction"]
