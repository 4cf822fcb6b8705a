"""Brunone's unsteady friction (``penstock.friction_model = "brunone"``): the instantaneous-acceleration-based (IAB)
model of Brunone, Golia and Greco (1991) in the sign form of Vitkovsky, Lambert and Simpson (2000), with Vardy and
Brown's shear-decay coefficient for the Brunone coefficient k3 (a friction model of
:mod:`simulate.components.hydraulic.friction`).

The friction slope (head per length, signed with the flow) is the steady one plus a term in the local and the
convective acceleration (equations numbered here; V the mean velocity, m/s, a the wave speed, m/s)::

    (B1)  J = f V|V| / (2 g D) + (k3 / (2 g)) (dV/dt + a sgn(V) |dV/dx|)     Vitkovsky et al. (2000), the IAB model
    (B2)  k3 = sqrt(C*) / 2                                                    Vardy and Brown's k3 from C*
    (B3)  C* = 0.00476 (Re < 2000),  C* = 7.41 / Re^kappa,  kappa = log10(14.3 / Re^0.05) (turbulent, smooth pipe)

Written with the flow Q = V A and integrated over one reach along a characteristic (dx = a dt), the head lost to
friction in the MOC's compatibility equations (:mod:`simulate.components.hydraulic.friction`) is::

    (B4)  Delta h_f = a dt J = R Q_j|Q_j| + (k3 / 2) B [(Q_j^n - Q_j^(n-1)) + sgn(Q_r + Q_(r+1)) |Q_(r+1) - Q_r|]

with R = f dx / (2 g D A^2) and B = a / (g A) of reach r, j the foot of the characteristic (r for C+, r+1 for C-),
flows of time level n, except in the last term on C+: there Q_r and Q_(r+1) are of level n-1. Explicit and first
order, in the manner of Bergant, Simpson and Vitkovsky (2001). The levels of the last term are those at which it
equals the time difference at the foot for a wave travelling upstream (Q(x + a t), dx = a dt), so the bracket
vanishes on the closure wave of the turbine in positive flow, as (B1)'s does: with level n on both lines the first
head peak of an instantaneous closure rises by k3/2 of the Joukowsky rise instead, and with the difference on the
upstream side of the foot a spike travels with the wave reflected at the reservoir. In steady flow (Q uniform and
constant) the bracket is zero and the loss is the steady one to the last bit; with k3 = 0 the model is the steady
one to the last bit.

The form is first order in time: the local term (Q_j^n - Q_j^(n-1)) is centred half a step before level n, and on an
oscillation of angular frequency w that lag turns a part w dt / 2 of the local-acceleration term (which stores and
returns energy) into damping, so the damping rate carries a relative error of the order of w dt. A peak within a few
periods of a closure converges to well under 0.1 % (the demo rejection: +0.0054 % / -0.0088 % on its extreme heads
from 8 to 16 reaches); a head read after 50 periods of ringing inherits the error (the surge-tank plant: -0.18 %,
then -0.089 %; ``benchmarks/bench_friction_decay.py``). Extrapolating the bracket of (B4) one step forward makes a
smooth ringing second order but overshoots the jump of a front reflected at the reservoir and grows after an
instantaneous closure. Limiting that extrapolation by the minmod of the bracket's last two changes (no extrapolation
where they differ in sign) keeps the instantaneous closure's decay (decrement 0.0333 per period, as (B4)) and makes
the surge-tank plant second order (-0.038 %, then -0.0064 %), but a closure over two steps spreads the front over
two brackets whose changes agree in sign, the extrapolation overshoots there, and the ringing gains energy (the
valve shut in 0.1 s of ``benchmarks/bench_tsnet_friction.py``: the second peak 0.6 m above the first, decrement
0.0089 per period against 0.0225). A second-order form needs the local term at the new level, implicit at each node:
with the convective term frozen by its sign, one of the two lines of a reach then carries the impedance B (1 + k3/2)
and the other B, so the node equations of the MOC and of its cavity models would take the impedance per line from
the friction model. The bracket stays as written.

TSNet (``tsnet/simulation/solver.py``, ``unsteady_friction``, and ``tsnet/simulation/main.py``) computes (B1)-(B3)
with the same time difference at the foot and the difference across the reach of level n-1 on both lines (the sign
that of the foot's velocity), and adds its unsteady term k3/(2g) (dV/dt + ...) to the velocity characteristic
without the factor g dt that its steady term f dt V|V| / (2 D) carries (its own comment asks to check the term);
(B4) keeps both terms in the same units.

References: B. Brunone, U. M. Golia, M. Greco, "Some remarks on the momentum equation for fast transients", Int.
Meeting on Hydraulic Transients with Column Separation, IAHR, Valencia, 1991. J. P. Vitkovsky, M. F. Lambert,
A. R. Simpson, "Advances in unsteady friction modelling in transient pipe flow", 8th Int. Conf. on Pressure Surges,
BHR, The Hague, 2000. A. E. Vardy, J. M. B. Brown, "On turbulent, unsteady, smooth-pipe friction", 7th Int. Conf. on
Pressure Surges, BHR, 1996. A. Bergant, A. R. Simpson, J. P. Vitkovsky, "Developments in unsteady pipe flow friction
modelling", J. Hydraulic Research 39(3), 2001.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from hillchart.errors import InputError
from simulate.components.contract import PER_NODE, StateArray
from simulate.components.hydraulic.friction import CompiledFriction, segment_reynolds
from simulate.components.parameters import parameter, validate_parameters

#: Its memory (the last array of its ``arrays``): the change of every node's flow over the last step, (B4).
STATES = (StateArray("flow_change", "m^3/s", "the change of each node's flow over the last step", PER_NODE),)
#: None: explicit on the MOC grid, whose step the penstock sets.
TIME_SCALES = ()
#: None: the unsteady term vanishes at a steady state; the linear model of the plant keeps the steady slope only.
LINEAR_COUNTERPART = None
#: The ``[penstock]`` keys of this model (refused under another friction model).
PENSTOCK_KEYS = ("brunone_k3", "brunone_viscosity_m2_s")
#: Reynolds number below which the flow is laminar in (B3).
LAMINAR_REYNOLDS = 2000.0


@dataclass(frozen=True)
class BrunoneConfig:
    """The keys of the Brunone model (``[penstock]`` keys ``brunone_k3``, ``brunone_viscosity_m2_s``)."""

    k3: float | None = parameter(None, unit="1", low=0.0, high=1.0,
                                 description="Brunone's coefficient k3 (brunone friction; default: from Vardy and "
                                             "Brown's shear-decay coefficient at the steady Reynolds number)")
    kinematic_viscosity_m2_s: float | None = parameter(
        None, unit="m^2/s", low=1e-7, high=1e-4,
        description="kinematic viscosity of the Reynolds number that sets k3 (brunone friction without brunone_k3; "
                    "default 1e-6, water at 20 C)")

    def __post_init__(self):
        validate_parameters("penstock", self)


def check_penstock(penstock, section: str = "penstock") -> None:
    """A given k3 leaves no use for the viscosity (it sets k3 only through the Reynolds number); ``section`` names
    the keys (``penstock`` or ``draft_tube``)."""
    if penstock.brunone_k3 is not None and penstock.brunone_viscosity_m2_s is not None:
        raise InputError(f"{section}.brunone_viscosity_m2_s = {penstock.brunone_viscosity_m2_s!r} would be ignored: "
                         f"{section}.brunone_k3 = {penstock.brunone_k3!r} is given (the viscosity sets k3 only "
                         f"through the Reynolds number); remove one of them")


def shear_decay_coefficient(reynolds: float) -> float:
    """Vardy and Brown's shear-decay coefficient C*, eq. (B3) of this module (smooth pipe).

    Examples
    --------
    >>> round(shear_decay_coefficient(1000.0), 5), round(shear_decay_coefficient(1e5), 7)
    (0.00476, 0.0002204)
    """
    if not (math.isfinite(reynolds) and reynolds >= 0.0):
        raise InputError(f"the Reynolds number of the Brunone coefficient must be a finite number >= 0, got "
                         f"{reynolds!r}")
    if reynolds < LAMINAR_REYNOLDS:
        return 0.00476  # eq. (B3), laminar
    kappa = math.log10(14.3 / reynolds ** 0.05)  # eq. (B3)
    return 7.41 / reynolds ** kappa  # eq. (B3), turbulent


def brunone_coefficient(reynolds: float) -> float:
    """k3 = sqrt(C*) / 2, eq. (B2) of this module.

    >>> round(brunone_coefficient(1e5), 5)
    0.00742
    """
    return math.sqrt(shear_decay_coefficient(reynolds)) / 2.0  # eq. (B2)


def segment_k3(penstock, flow_m3_s: float) -> list[float]:
    """k3 of every segment: the given ``brunone_k3``, or eq. (B2) at the segment's steady Reynolds number
    Re = |Q| D / (A nu)."""
    if penstock.brunone_k3 is not None:
        return [float(penstock.brunone_k3)] * len(penstock.segments)
    return [brunone_coefficient(re) for re in segment_reynolds(penstock, flow_m3_s, penstock.brunone_viscosity_m2_s)]


@numba.njit(cache=True)
def brunone_reach_loss(friction, flows, reach, node):
    """Delta h_f of reach ``reach`` on the characteristic whose foot is node ``node`` (``reach``: C+, ``reach + 1``:
    C-), eq. (B4) of this module, m.

    ``friction`` = (R per reach (s^2/m^5), (k3 / 2) B per reach (s/m^2), Q^n - Q^(n-1) per node (m^3/s))."""
    steady, unsteady, change = friction
    q = flows[node]
    up, down = flows[reach], flows[reach + 1]
    if node == reach:  # C+: the reach one step earlier, eq. (B4)
        up, down = up - change[reach], down - change[reach + 1]
    gradient = down - up
    mean = up + down  # the sign of the reach's flow at the level of the difference
    sign = 1.0 if mean > 0.0 else (-1.0 if mean < 0.0 else 0.0)
    return steady[reach] * q * abs(q) + unsteady[reach] * (change[node] + sign * abs(gradient))


@numba.njit(cache=True)
def brunone_advance(friction, flows, new_flows):
    """Keep Q^(n+1) - Q^n of every node for the next step's local acceleration."""
    change = friction[2]
    for j in range(change.size):
        change[j] = new_flows[j] - flows[j]


def build_brunone_friction(penstock, grid, flow_m3_s: float) -> CompiledFriction:
    """The Brunone model on ``grid``, started from steady flow (no acceleration)."""
    k3 = segment_k3(penstock, flow_m3_s)
    per_reach = np.repeat(np.array(k3), grid.reaches_per_segment)
    unsteady = 0.5 * per_reach * grid.impedance_s_m2  # (k3 / 2) B, eq. (B4)
    change = np.zeros(grid.impedance_s_m2.size + 1)
    return CompiledFriction("brunone", brunone_reach_loss, brunone_advance,
                            (grid.friction_s2_m5, unsteady, change),
                            summary={"brunone_k3_min": min(k3), "brunone_k3_max": max(k3)})


__all__ = ["PENSTOCK_KEYS", "BrunoneConfig", "check_penstock", "shear_decay_coefficient", "brunone_coefficient",
           "segment_k3", "brunone_reach_loss", "brunone_advance", "build_brunone_friction"]
