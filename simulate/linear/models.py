"""Linear models of the turbine-penstock-rotor system built from the six transfer coefficients.

Paper 000 (Wang et al. 2023), sections 2-4, and paper 002 (Wei et al. 2016). All signals are relative increments
about the operating point O: ``x = dn/n0`` (speed), ``h = dH/H0`` (head), ``y = da/a0`` (opening, paper 000's
``Delta u``), ``m``, ``q``, ``m_L`` (load torque).

Equations used (paper 000 unless said otherwise)::

    m = ex x + ey y + eh h,  q = eqx x + eqy y + eqh h            eqs. (4)-(7)
    Ta dx/dt = m - m_L,   m_L = e_g x + m_g0                       eqs. (8), (13)  (J of the paper = Ta, s)
    rigid (inelastic) water:  h = -Tw dq/dt                        eq. (9)
    elastic water (lumped):   alpha Te^2 d2h/dt2 + h = -Tw dq/dt   eqs. (16)-(18), Te = L / a
    state space  dX/dt = A X + B1 y + B2 dy/dt + L0 m_g0           eqs. (10)-(12) (X = [x, h]),
                                                                   eqs. (24)-(30) (X = [x, h, dh/dt])
    zero-order hold G = exp(A tau), H_B = int_0^tau exp(A s) B ds   eqs. (32)-(36)
    x/y = N2/D2 (rigid), N3/D3 (elastic)                           eqs. (43)-(44), (51)-(52)
    ARX x(k+1) = a1 x(k) + a2 x(k-1) + a3 x(k-2) + b.. y(..)       eq. (53)

Extension (not in the paper, off by default): ``friction_slope`` r_f = 2 h_f0 / H0 adds the linearized steady
penstock friction, ``h = -r_f q + h_w`` with ``D_p h_w = -Tw s q`` (as the simulator applies friction to the lumped and
rigid models); it folds into effective coefficients (:meth:`LinearPlant.effective_coefficients`), so with or without
it the matrices have the paper's form, and with r_f = 0 they are exactly the paper's. The grid self-regulation e_g
enters as ``ex - e_g`` (eq. (13) substituted in eq. (8)).

About the B2 dy/dt input of eq. (32): with a piecewise-constant opening, dy/dt is a sum of Dirac impulses, so eq. (32)
cannot be used with a sampled dy/dt. Writing ``X~ = X - B2 y`` gives the single-input system
``dX~/dt = A X~ + (B1 + A B2) y + L0 m_g0`` whose zero-order hold is exact; in the paper's terms
``X(k+1) = G X(k) + H_B1 y(k) + B2 (y(k+1) - y(k)) + H_L m_g0(k)`` (since ``int exp(A s) A B2 ds = (G - I) B2``).
:meth:`DiscreteStateSpace.simulate` uses that form; the speed x (first state) never sees the B2 jump.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from hillchart.errors import InputError, NumericalError
from hillchart.linearize import COEFFICIENT_NAMES

#: Default lumped-penstock factor: 4/pi^2 puts the pole of h = -Tw s / (1 + alpha Te^2 s^2) q on the first
#: resonance of the exact frictionless line, tanh(Te s) (pole at Te s = j pi / 2).
DEFAULT_ALPHA = 4.0 / np.pi**2


def _six_tuple(coefficients) -> tuple[float, ...]:
    """``(ex, ey, eh, eqx, eqy, eqh)`` from a SixCoefficients-like object, a dict or a 6-sequence."""
    if isinstance(coefficients, dict):
        missing = [k for k in COEFFICIENT_NAMES if k not in coefficients]
        if missing:
            raise InputError(f"coefficients dict is missing {missing}; expected keys {list(COEFFICIENT_NAMES)}")
        values = [coefficients[k] for k in COEFFICIENT_NAMES]
    elif all(hasattr(coefficients, k) for k in COEFFICIENT_NAMES):
        values = [getattr(coefficients, k) for k in COEFFICIENT_NAMES]
    else:
        values = list(np.asarray(coefficients, dtype=float).ravel())
        if len(values) != 6:
            raise InputError(f"coefficients must be 6 values (ex, ey, eh, eqx, eqy, eqh), got {len(values)}")
    values = [float(v) for v in values]
    for name, value in zip(COEFFICIENT_NAMES, values):
        if not np.isfinite(value):
            raise InputError(f"coefficient {name} must be finite, got {value!r}")
    return tuple(values)


@dataclass(frozen=True, eq=False)
class DiscreteStateSpace:
    """Zero-order-hold discretization of a :class:`StateSpace` (paper 000, eqs. (32)-(36)).

    Attributes
    ----------
    G : ndarray (n, n)         ``exp(A tau)``, eq. (33)
    HB1, HB2, HL : ndarray (n,) ``int_0^tau exp(A s) B ds`` for B1, B2, L0, eqs. (34)-(36)
    B2 : ndarray (n,)          the continuous B2 (for the exact jump form, see module docstring)
    sample_time_s : float      tau, s
    state_names : tuple of str
    """

    G: np.ndarray
    HB1: np.ndarray
    HB2: np.ndarray
    HL: np.ndarray
    B2: np.ndarray
    sample_time_s: float
    state_names: tuple

    def simulate(self, opening, load=None, x0=None) -> np.ndarray:
        """States at the samples for a piecewise-constant opening (and load torque) held over each interval.

        ``X(k+1) = G X(k) + HB1 y(k) + B2 (y(k+1) - y(k)) + HL m_g0(k)`` (exact; see module docstring).

        Parameters
        ----------
        opening : array_like (N,)
            Relative opening y(k), held on [k tau, (k+1) tau); y(-1) = 0, so a nonzero y(0) is a step at t = 0.
        load : array_like (N,), optional
            Relative load torque m_g0(k); zero when omitted.
        x0 : array_like (n,), optional
            State just before t = 0 (zero: the operating point).

        Returns
        -------
        ndarray (N + 1, n)
            X(0+) ... X(N): row k is the state at t = k tau (after the opening jump at that instant).
        """
        y = np.asarray(opening, dtype=float).ravel()
        n_samples = y.size
        mg = np.zeros(n_samples) if load is None else np.asarray(load, dtype=float).ravel()
        if mg.size != n_samples:
            raise InputError(f"load must have the length of opening ({n_samples}), got {mg.size}")
        n = self.G.shape[0]
        state = np.zeros(n) if x0 is None else np.asarray(x0, dtype=float).ravel().copy()
        if state.size != n:
            raise InputError(f"x0 must have {n} entries {self.state_names}, got {state.size}")
        out = np.empty((n_samples + 1, n))
        state = state + self.B2 * y[0]  # jump at t = 0 from y(-1) = 0 to y(0)
        out[0] = state
        for k in range(n_samples):
            y_next = y[k + 1] if k + 1 < n_samples else y[k]
            state = self.G @ state + self.HB1 * y[k] + self.B2 * (y_next - y[k]) + self.HL * mg[k]
            out[k + 1] = state
        return out


@dataclass(frozen=True, eq=False)
class StateSpace:
    """``dX/dt = A X + B1 y + B2 dy/dt + L0 m_g0`` (paper 000, eq. (11) / (25)-(26)).

    Attributes
    ----------
    A : ndarray (n, n)
    B1, B2, L0 : ndarray (n,)
    state_names : tuple of str
        ``("x", "h")`` (rigid water) or ``("x", "h", "dh_dt")`` (elastic water; dh_dt in 1/s); with friction the
        head states are those of the water column alone, h_w.
    head_row : ndarray (n,), head_feedthrough : float
        Turbine head ``h = head_row . X + head_feedthrough y`` (``[0, 1, (0)]`` and 0 without friction).
    """

    A: np.ndarray
    B1: np.ndarray
    B2: np.ndarray
    L0: np.ndarray
    state_names: tuple
    head_row: np.ndarray | None = None
    head_feedthrough: float = 0.0

    def __post_init__(self):
        if self.head_row is None:  # the paper's case: the second state is the head
            row = np.zeros(self.A.shape[0])
            row[1] = 1.0
            object.__setattr__(self, "head_row", row)

    def head(self, states, opening) -> np.ndarray:
        """Turbine head h from states (rows) and the opening y at the same instants."""
        return np.asarray(states) @ self.head_row + self.head_feedthrough * np.asarray(opening, dtype=float)

    def eigenvalues(self) -> np.ndarray:
        """Eigenvalues of A, 1/s (open-loop stability: all real parts < 0)."""
        return np.linalg.eigvals(self.A)

    def is_stable(self) -> bool:
        """True when every eigenvalue of A lies strictly in the left half plane."""
        return bool(np.all(np.real(self.eigenvalues()) < 0))

    def single_input(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(A, B, C, D)`` of the opening -> (x, h) system without the dy/dt input.

        With ``X~ = X - B2 y``: ``dX~/dt = A X~ + (B1 + A B2) y`` and ``X = X~ + B2 y`` (module docstring), so
        ``C`` selects x and h and ``D = C B2`` (zero for x: the speed has no direct feed-through).
        """
        n = self.A.shape[0]
        C = np.zeros((2, n))
        C[0, 0] = 1.0
        C[1] = self.head_row
        B = (self.B1 + self.A @ self.B2).reshape(n, 1)
        D = (C @ self.B2 + np.array([0.0, self.head_feedthrough])).reshape(2, 1)
        return self.A.copy(), B, C, D

    def discretize(self, sample_time_s: float) -> DiscreteStateSpace:
        """Zero-order hold by one matrix exponential (Van Loan's augmented matrix), paper 000 eqs. (32)-(36).

        ``expm([[A, B1, B2, L0], [0, 0, 0, 0]] tau) = [[G, HB1, HB2, HL], [0, I]]``.

        Parameters
        ----------
        sample_time_s : float
            tau, s, > 0.

        Returns
        -------
        DiscreteStateSpace
        """
        tau = _positive("sample_time_s", sample_time_s)
        n = self.A.shape[0]
        M = np.zeros((n + 3, n + 3))
        M[:n, :n] = self.A
        M[:n, n] = self.B1
        M[:n, n + 1] = self.B2
        M[:n, n + 2] = self.L0
        E = scipy.linalg.expm(M * tau)
        if not np.all(np.isfinite(E)):
            raise NumericalError(f"exp(A tau) is not finite for tau = {tau} s; eigenvalues {self.eigenvalues()}")
        return DiscreteStateSpace(
            G=E[:n, :n],  # eq. (33)
            HB1=E[:n, n],  # eq. (34)
            HB2=E[:n, n + 1],  # eq. (35)
            HL=E[:n, n + 2],  # eq. (36)
            B2=self.B2.copy(),
            sample_time_s=tau,
            state_names=self.state_names,
        )


def _positive(name: str, value, *, allow_zero: bool = False) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(f"{name} must be a number, got {value!r}")  # not True, not "3"
    v = float(value)
    if not np.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise InputError(f"{name} must be finite and {bound}, got {value!r}")
    return v


@dataclass(frozen=True)
class LinearPlant:
    """Linear turbine + penstock + rotor around an operating point (paper 000, section 2).

    Parameters
    ----------
    ex, ey, eh, eqx, eqy, eqh : float
        The six transfer coefficients (see :mod:`hillchart.linearize`).
    water_time_s : float
        Water inertia time Tw = L Q0 / (g A H0), s, > 0 (eq. (9)).
    inertia_time_s : float
        Mechanical time Ta (the paper's J) with ``Ta dx/dt = m - m_L``, s, > 0.
    self_regulation : float
        Grid/load self-regulation e_g >= 0 (``m_L = e_g x + m_g0``, eq. (13)).
    wave_time_s : float
        Wave travel time Te = L / a, s. 0 (default) is rigid (inelastic) water, eqs. (10)-(12); > 0 is the lumped
        elastic model, eqs. (24)-(30).
    alpha : float
        Factor of ``alpha Te^2 s^2`` in the lumped elastic penstock (eq. (16)); > 0. Default 4/pi^2.
    friction_slope : float
        Extension, not in the paper: r_f = 2 h_f0 / H0 >= 0, linearized penstock friction (default 0 = the paper).

    Examples
    --------
    >>> plant = LinearPlant(ex=-1, ey=1, eh=1.5, eqx=0, eqy=1, eqh=0.5, water_time_s=1.0, inertia_time_s=8.0)
    >>> plant.state_space().is_stable()
    True
    >>> num, den = plant.speed_transfer_function()
    >>> [float(c) for c in num], [float(c) for c in den]
    ([-1.0, 1.0], [4.0, 8.5, 1.0])
    """

    ex: float
    ey: float
    eh: float
    eqx: float
    eqy: float
    eqh: float
    water_time_s: float
    inertia_time_s: float
    self_regulation: float = 0.0
    wave_time_s: float = 0.0
    alpha: float = DEFAULT_ALPHA
    friction_slope: float = 0.0

    def __post_init__(self):
        _six_tuple([getattr(self, k) for k in COEFFICIENT_NAMES])
        _positive("water_time_s", self.water_time_s)
        _positive("inertia_time_s", self.inertia_time_s)
        _positive("self_regulation", self.self_regulation, allow_zero=True)
        _positive("wave_time_s", self.wave_time_s, allow_zero=True)
        _positive("alpha", self.alpha)
        _positive("friction_slope", self.friction_slope, allow_zero=True)
        if self.eqh == 0:
            raise InputError("eqh must be != 0: the head equation divides by eqh (Wang et al. 2023, eq. (12))")

    @classmethod
    def from_coefficients(cls, coefficients, **parameters) -> "LinearPlant":
        """Build from a :class:`~hillchart.linearize.SixCoefficients` (or dict / 6-sequence) plus the parameters."""
        values = dict(zip(COEFFICIENT_NAMES, _six_tuple(coefficients)))
        return cls(**values, **parameters)

    @property
    def coefficients(self) -> tuple[float, ...]:
        """``(ex, ey, eh, eqx, eqy, eqh)``."""
        return tuple(float(getattr(self, k)) for k in COEFFICIENT_NAMES)

    @property
    def elastic(self) -> bool:
        """True for the lumped elastic penstock (wave_time_s > 0)."""
        return self.wave_time_s > 0

    @property
    def penstock_model(self) -> str:
        """``"lumped"`` or ``"rigid"`` (the simulator's penstock model this linear model matches)."""
        return "lumped" if self.elastic else "rigid"

    def effective_coefficients(self) -> tuple[float, ...]:
        """Six coefficients with the linearized penstock friction folded in (equal to the six when r_f = 0).

        The steady friction acts on the flow algebraically, ``h = h_w - r_f q``, where h_w is the head the rigid or
        lumped water column alone gives (``D_p h_w = -Tw s q``). Substituting in eqs. (4)-(5) with
        ``k = 1 / (1 + eqh r_f)``::

            q = k (eqx x + eqy y + eqh h_w)
            m = (ex - eh r_f k eqx) x + (ey - eh r_f k eqy) y + eh k h_w

        so the plant with friction is the paper's plant in the state h_w with these coefficients.
        """
        ex, ey, eh, eqx, eqy, eqh = self.coefficients
        rf = self.friction_slope
        k = 1.0 / (1.0 + eqh * rf)
        return ex - eh * rf * k * eqx, ey - eh * rf * k * eqy, eh * k, eqx * k, eqy * k, eqh * k

    def state_space(self) -> StateSpace:
        """A, B1, B2, L0 (paper 000 eqs. (10)-(12) rigid, (24)-(30) elastic).

        With friction (r_f > 0) the matrices are the paper's for :meth:`effective_coefficients` and the second
        state is h_w (``head_row``/``head_feedthrough`` of the record give the turbine head h).
        """
        ex, eu, eh, eqx, equ, eqh = self.effective_coefficients()
        ex = ex - self.self_regulation  # eq. (13) in eq. (8): Ta dx/dt = (ex - e_g) x + ... - m_g0
        J, Tw = self.inertia_time_s, self.water_time_s
        if not self.elastic:
            # eq. (12): from Ta x' = ex x + eh h + eu y - m_g0, h = -Tw q', q = eqx x + equ y + eqh h
            A = np.array(
                [
                    [ex / J, eh / J],
                    [-eqx * ex / (eqh * J), -(eh * eqx / (eqh * J) + 1.0 / (eqh * Tw))],
                ]
            )
            B1 = np.array([eu / J, -eqx * eu / (eqh * J)])
            B2 = np.array([0.0, -equ / eqh])
            L0 = np.array([-1.0 / J, eqx / (eqh * J)])
            names = ("x", "h") if self.friction_slope == 0 else ("x", "h_w")
        else:
            aT2 = self.alpha * self.wave_time_s**2
            # eqs. (25)-(30): alpha Te^2 h'' + Tw eqh h' + h = -Tw eqx x' - Tw equ y', x' from eq. (23)
            A = np.array(
                [
                    [ex / J, eh / J, 0.0],
                    [0.0, 0.0, 1.0],
                    [-Tw * eqx * ex / (aT2 * J), -(J + Tw * eqx * eh) / (aT2 * J), -Tw * eqh / aT2],
                ]
            )
            B1 = np.array([eu / J, 0.0, -Tw * eqx * eu / (aT2 * J)])
            B2 = np.array([0.0, 0.0, -Tw * equ / aT2])
            L0 = np.array([-1.0 / J, 0.0, Tw * eqx / (aT2 * J)])
            names = ("x", "h", "dh_dt") if self.friction_slope == 0 else ("x", "h_w", "dh_w_dt")
        # turbine head h = h_w - r_f q = k h_w - r_f k (eqx x + eqy y) (see effective_coefficients)
        _, _, _, eqx0, _, eqh0 = self.coefficients
        eqy0 = self.eqy
        rf = self.friction_slope
        k = 1.0 / (1.0 + eqh0 * rf)
        head_row = np.zeros(A.shape[0])
        head_row[0] = -rf * k * eqx0
        head_row[1] = k
        return StateSpace(A=A, B1=B1, B2=B2, L0=L0, state_names=names, head_row=head_row,
                          head_feedthrough=-rf * k * eqy0)

    def _penstock_polynomials(self):
        """``(N_p, D_p)`` of ``D_p(s) h = -N_p(s) q`` (highest power first): ``N_p = Tw s + r_f D_p``."""
        d_p = np.array([self.alpha * self.wave_time_s**2, 0.0, 1.0]) if self.elastic else np.array([1.0])
        n_p = np.polyadd([self.water_time_s, 0.0], self.friction_slope * d_p)
        return n_p, d_p

    def speed_transfer_function(self) -> tuple[np.ndarray, np.ndarray]:
        """``x(s)/y(s) = N(s)/D(s)``: N2/D2 (eqs. (43)-(44)) for rigid water, N3/D3 (eqs. (51)-(52)) for elastic.

        From ``Ta s x = ex x + eh h + ey y`` (eq. (38)) and ``D_p h = -N_p q`` (eqs. (39), (48)):
        ``D = (Ta s - ex)(D_p + eqh N_p) + eh eqx N_p`` and ``N = ey (D_p + eqh N_p) - eh eqy N_p``.

        Returns
        -------
        num, den : ndarray
            Polynomial coefficients in s, highest power first (scipy.signal convention).
        """
        ex, eu, eh, eqx, equ, eqh = self.coefficients
        ex = ex - self.self_regulation
        n_p, d_p = self._penstock_polynomials()
        p = np.polyadd(d_p, eqh * n_p)
        den = np.polyadd(np.polymul([self.inertia_time_s, -ex], p), eh * eqx * n_p)
        num = np.polysub(eu * p, eh * equ * n_p)
        return np.trim_zeros(num, "f"), np.trim_zeros(den, "f")

    def head_transfer_function(self) -> tuple[np.ndarray, np.ndarray]:
        """``h(s)/y(s)`` (eq. (45)-(47) of paper 000, simplified): ``-N_p (eqx ey + eqy (Ta s - ex)) / D``."""
        ex, eu, eh, eqx, equ, eqh = self.coefficients
        ex = ex - self.self_regulation
        n_p, _ = self._penstock_polynomials()
        _, den = self.speed_transfer_function()
        num = -np.polymul(n_p, np.polyadd([equ * self.inertia_time_s, -equ * ex], [eqx * eu]))
        return np.trim_zeros(num, "f"), den

    def arx(self, sample_time_s: float) -> "ArxModel":
        """ARX model of x driven by y that the zero-order hold of this plant implies (eq. (53), exact structure).

        The speed transfer function is strictly proper of order n (2 rigid, 3 elastic), so its zero-order hold is
        ``x(k+1) = sum_i a_i x(k+1-i) + sum_j b_j y(k+1-j)`` with n a's and n b's (input delay 0).

        Parameters
        ----------
        sample_time_s : float
            tau, s.

        Returns
        -------
        ArxModel
        """
        tau = _positive("sample_time_s", sample_time_s)
        ss = self.state_space()
        disc = ss.discretize(tau)  # eqs. (32)-(36) by expm
        n = ss.A.shape[0]
        # single-input form X~ = X - B2 y (module docstring): Gamma = H_B1 + (G - I) B2, output x = X~[0]
        gamma = (disc.HB1 + (disc.G - np.eye(n)) @ ss.B2).reshape(n, 1)
        c_x = np.zeros((1, n))
        c_x[0, 0] = 1.0
        # scipy.signal.ss2tf's own formula for one input and one output with D = 0: den = det(zI - G),
        # num = det(zI - G + Gamma C) - den. Written out with numpy.poly so that identification does not import
        # scipy.signal (about 1 s of start-up); tests check it against scipy.signal.cont2discrete.
        den = np.poly(disc.G)
        num = (np.poly(disc.G - gamma @ c_x) - den).reshape(1, -1)
        num = np.atleast_1d(np.squeeze(num))
        den = np.atleast_1d(den)
        num = num / den[0]
        den = den / den[0]
        if abs(num[0]) > 1e-12 * max(1.0, np.abs(num).max()):
            raise NumericalError(f"zero-order hold of x/y has a direct feed-through {num[0]}; expected 0")
        return ArxModel(a=-den[1:], b=num[1:n + 1], input_delay=0, sample_time_s=tau)

    def step_response(self, sample_time_s: float, n_samples: int, *, amplitude: float = 1.0) -> np.ndarray:
        """Sampled response (x, h) to an opening step ``y = amplitude`` at t = 0, by the exact zero-order hold.

        Returns
        -------
        ndarray (n_samples + 1, 2)
            Columns x and h at t = 0+, tau, ..., n_samples tau.
        """
        if int(n_samples) != n_samples or n_samples < 1:
            raise InputError(f"n_samples must be an integer >= 1, got {n_samples!r}")
        ss = self.state_space()
        states = ss.discretize(sample_time_s).simulate(np.full(int(n_samples), float(amplitude)))
        return np.column_stack([states[:, 0], ss.head(states, float(amplitude))])


@dataclass(frozen=True, eq=False)
class ArxModel:
    """``x(k+1) = sum_{i=1}^{na} a_i x(k+1-i) + sum_{j=1}^{nb} b_j y(k+1-j-d)`` (paper 000 eq. (53), d = input_delay).

    Paper 000 writes eq. (53) with na = 3, nb = 2, d = 1 (``b1 u(k-1) + b2 u(k-2)``); the exact zero-order hold of
    the third-order N3/D3 has na = nb = 3, d = 0. The load term c0 d(k) is dropped (constant load, d(k) = 0).

    Attributes
    ----------
    a : ndarray (na,)
    b : ndarray (nb,)
    input_delay : int
    sample_time_s : float
    """

    a: np.ndarray
    b: np.ndarray
    input_delay: int = 0
    sample_time_s: float = field(default=float("nan"))

    def __post_init__(self):
        object.__setattr__(self, "a", np.atleast_1d(np.asarray(self.a, dtype=float)))
        object.__setattr__(self, "b", np.atleast_1d(np.asarray(self.b, dtype=float)))
        if self.a.ndim != 1 or self.b.ndim != 1:
            raise InputError("ArxModel.a and .b must be one-dimensional")
        if not (np.all(np.isfinite(self.a)) and np.all(np.isfinite(self.b))):
            raise InputError(f"ArxModel coefficients must be finite, got a={self.a}, b={self.b}")
        if int(self.input_delay) != self.input_delay or self.input_delay < 0:
            raise InputError(f"ArxModel.input_delay must be an integer >= 0, got {self.input_delay!r}")

    @classmethod
    def from_theta(cls, theta, *, n_a: int, n_b: int, input_delay: int = 0, sample_time_s: float = float("nan")):
        """Split ``theta = [a_1..a_na, b_1..b_nb]`` (eq. (54) ordering)."""
        theta = np.asarray(theta, dtype=float).ravel()
        if theta.size != n_a + n_b:
            raise InputError(f"theta must have n_a + n_b = {n_a + n_b} entries, got {theta.size}")
        return cls(a=theta[:n_a], b=theta[n_a:], input_delay=input_delay, sample_time_s=sample_time_s)

    @property
    def theta(self) -> np.ndarray:
        """``[a_1, ..., a_na, b_1, ..., b_nb]`` (eq. (54))."""
        return np.concatenate([self.a, self.b])

    @property
    def n_a(self) -> int:
        return int(self.a.size)

    @property
    def n_b(self) -> int:
        return int(self.b.size)

    def simulate(self, opening, *, x_initial=None) -> np.ndarray:
        """Simulation-mode output (eqs. (62)-(63)): past outputs are the model's own, inputs are measured.

        Parameters
        ----------
        opening : array_like (N,)
            y(0..N-1); samples before 0 are taken as zero.
        x_initial : array_like, optional
            Known outputs x(0..p-1) used to start (default: x(0) = 0 and zeros before).

        Returns
        -------
        ndarray (N,)
            x_hat(0..N-1); x_hat(k) = x_initial(k) for the given initial samples.
        """
        y = np.asarray(opening, dtype=float).ravel()
        n = y.size
        x = np.zeros(n)
        start = 1
        if x_initial is not None:
            xi = np.asarray(x_initial, dtype=float).ravel()
            if xi.size == 0 or xi.size > n:
                raise InputError(f"x_initial must have 1..{n} samples, got {xi.size}")
            x[: xi.size] = xi
            start = xi.size
        d = int(self.input_delay)
        for k in range(start - 1, n - 1):  # computes x(k+1)
            acc = 0.0
            for i, ai in enumerate(self.a, start=1):
                j = k + 1 - i
                if j >= 0:
                    acc += ai * x[j]
            for i, bi in enumerate(self.b, start=1):
                j = k + 1 - i - d
                if j >= 0:
                    acc += bi * y[j]
            x[k + 1] = acc
        return x

    def step_response(self, n_samples: int, *, amplitude: float = 1.0) -> np.ndarray:
        """x(0..n_samples) for y(k) = amplitude, k >= 0 (zero before), x(0) = 0."""
        if int(n_samples) != n_samples or n_samples < 1:
            raise InputError(f"n_samples must be an integer >= 1, got {n_samples!r}")
        return self.simulate(np.full(int(n_samples) + 1, float(amplitude)))

    def to_dict(self) -> dict:
        return {
            "a": [float(v) for v in self.a],
            "b": [float(v) for v in self.b],
            "input_delay": int(self.input_delay),
            "sample_time_s": float(self.sample_time_s),
        }


# ----------------------------------------------------------------------------------------------------------------
# Paper 002: torque response to opening with rigid water hammer, and its ARMA form
# ----------------------------------------------------------------------------------------------------------------


def combined_coefficient(coefficients) -> float:
    """Paper 002's ``e = eqy eh / ey - eqh`` (text under eq. (1)).

    Examples
    --------
    >>> combined_coefficient((-1.0, 1.0, 1.5, 0.0, 1.0, 0.5))
    1.0
    """
    _, ey, eh, _, eqy, eqh = _six_tuple(coefficients)
    if ey == 0:
        raise InputError("ey must be != 0 for e = eqy eh / ey - eqh, got 0")
    return eqy * eh / ey - eqh


def torque_transfer_function(*, ey: float, e: float, eqh: float, water_time_s: float):
    """``G_t(s) = m(s)/y(s) = ey (1 - e Tw s) / (1 + eqh Tw s)`` (paper 002, eq. (3)), speed held constant.

    Returns
    -------
    num, den : ndarray
        Highest power of s first.

    Examples
    --------
    >>> num, den = torque_transfer_function(ey=1.0, e=1.0, eqh=0.5, water_time_s=2.0)   # eq. (4), Tw = 2 s
    >>> [float(v) for v in num], [float(v) for v in den]
    ([-2.0, 1.0], [1.0, 1.0])
    """
    tw = _positive("water_time_s", water_time_s)
    for name, value in (("ey", ey), ("e", e), ("eqh", eqh)):
        if not np.isfinite(value):
            raise InputError(f"{name} must be finite, got {value!r}")
    return np.array([-ey * e * tw, ey]), np.array([eqh * tw, 1.0])


def arma_coefficients(*, ey: float, e: float, eqh: float, water_time_s: float, sample_time_s: float):
    """``(a, b, c)`` of ``m(k) = -a m(k-1) + b y(k) + c y(k-1)`` (paper 002 eqs. (6)-(8)).

    Backward-difference discretization of eq. (3) with step Dt::

        a = -eqh Tw / (eqh Tw + Dt),  b = ey (Dt - e Tw) / (eqh Tw + Dt),  c = ey e Tw / (eqh Tw + Dt)   # eq. (8)

    Examples
    --------
    >>> [round(v, 6) for v in arma_coefficients(ey=1.0, e=1.0, eqh=0.5, water_time_s=2.0, sample_time_s=0.2)]
    [-0.833333, -1.5, 1.666667]
    """
    tw = _positive("water_time_s", water_time_s)
    dt = _positive("sample_time_s", sample_time_s)
    den = eqh * tw + dt
    if den == 0:
        raise InputError(f"eqh Tw + Dt must be != 0, got eqh={eqh}, Tw={tw}, Dt={dt}")
    a = -eqh * tw / den  # eq. (8)
    b = ey * (dt - e * tw) / den  # eq. (8)
    c = ey * e * tw / den  # eq. (8)
    return float(a), float(b), float(c)


def turbine_parameters_from_arma(a: float, b: float, c: float, *, water_time_s: float, sample_time_s: float):
    """Inverse of :func:`arma_coefficients`: ``(ey, e, eqh)`` from ``(a, b, c)`` given Tw and Dt (paper 002 eq. (8)).

    From eq. (8): ``eqh Tw + Dt = Dt / (1 + a)``, hence ``eqh = -a Dt / ((1 + a) Tw)``, ``ey = (b + c) / (1 + a)``
    and ``e = c Dt / ((b + c) Tw)``. The map is unique (paper 002, conclusions) when ``a != -1`` and ``b + c != 0``.

    Examples
    --------
    >>> [round(v, 12) for v in turbine_parameters_from_arma(-0.8333333333333334, -1.5, 1.6666666666666667,
    ...                                                    water_time_s=2.0, sample_time_s=0.2)]
    [1.0, 1.0, 0.5]
    """
    tw = _positive("water_time_s", water_time_s)
    dt = _positive("sample_time_s", sample_time_s)
    a, b, c = (float(v) for v in (a, b, c))
    if not all(np.isfinite(v) for v in (a, b, c)):
        raise InputError(f"ARMA coefficients must be finite, got a={a}, b={b}, c={c}")
    if a == -1.0:
        raise InputError("ARMA coefficient a must be != -1 (pure integrator): eqh would be infinite")
    if b + c == 0.0:
        raise InputError("ARMA coefficients need b + c != 0 (zero static gain ey): e is undefined")
    eqh = -a * dt / ((1.0 + a) * tw)
    ey = (b + c) / (1.0 + a)
    e = c * dt / ((b + c) * tw)
    return float(ey), float(e), float(eqh)
