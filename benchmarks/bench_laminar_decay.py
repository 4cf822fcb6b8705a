"""The classical damping case of unsteady friction: a valve shut at once at the end of a laminar pipe, and the decay
of the ringing that follows, against the exact theory of laminar transient flow.

    PYTHONPATH=$PWD python benchmarks/bench_laminar_decay.py

In laminar flow the wall shear of a transient is known exactly: the axisymmetric Navier-Stokes equations of a pipe,
transformed in time (Laplace variable s), give the series impedance of the water column per length and so the
propagation operator (D'Souza and Oldenburger, J. Basic Eng. 86, 1964; Zielke, "Frequency-dependent friction in
transient pipe flow", J. Basic Eng. 90(1), 109-115, 1968, eqs. 6-12, from which his weighting function, (U2) of
:mod:`simulate.components.hydraulic.convolution`, is the inverse transform)::

    (L1)  Gamma(s) = (s / a) / sqrt(F(s)),   F(s) = 1 - 2 J1(k) / (k J0(k)),   k = i R sqrt(s / nu)
    (L2)  Gamma(s) = (s / a) sqrt(1 / F(s) - 8 nu / (R^2 s))     (L1) without its steady part 32 nu V / (g D^2)

(R the pipe's radius, nu the kinematic viscosity, a the wave speed; for large s, F -> 1 and Gamma -> s / a). A pipe
from a reservoir (head fixed) to a shut valve (flow zero) rings in the modes cosh(Gamma L) = 0; the fundamental's
complex frequency s_1 solves

    (L3)  Gamma(s_1) L = i pi / 2,    s_1 = -sigma + i omega

(secant iteration from the frictionless i pi a / (2 L)): the head at the valve decays as exp(-sigma t) and rings at
omega. The case: L = 40 m, D = 20 mm, a = 1000 m/s, nu = 1e-6 m^2/s, 20 m of head, V0 = 0.05 m/s (Re = 1000), the
valve (the ideal turbine at full stroke) shut linearly in 2 ms from t = 0.01 s; MOC with 20 to 160 reaches (the step
2 ms to 0.25 ms). sigma and omega of a run: the head at the valve over whole periods 2 pi / omega_exact from t = 0.3 s
(once the closure's higher modes, which decay faster, have faded), projected on exp(-i omega t) per period; sigma the
slope of the log of those amplitudes, omega the exact one corrected by their mean phase drift.

Prints three models against the exact (L1)/(L2):

* the convolution (Zielke's weighting) **without the steady loss** (``darcy_friction = 0``) against (L2): the
  unsteady wall shear alone, which the convolution claims to reproduce exactly;
* the convolution with the steady loss (Darcy f = 64 / Re at the initial flow) against (L1): the simulator's laminar
  steady loss is ``f V|V|`` with ``f`` fixed at the initial Reynolds number, quadratic where Hagen-Poiseuille is
  linear, so its share of the damping (a tenth here) falls with the amplitude: sigma is printed over the early and
  the late windows;
* the quasi-steady loss alone (``friction_model = "steady"``), the model a user had before the unsteady ones.
"""

from __future__ import annotations

import argparse
import cmath
import math
import sys
from pathlib import Path

import numpy as np
from scipy.special import jve

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from hillchart.constants import G_M_S2, RHO_WATER_KG_M3  # noqa: E402
from simulate.config import (GeneratorConfig, GovernorConfig, PenstockConfig, PenstockSegment, PlantConfig,  # noqa: E402
                             ScenarioConfig, SolverConfig, TurbineConfig)
from simulate.loop.engine import run_simulation  # noqa: E402

LENGTH_M, DIAMETER_M, WAVE_SPEED_M_S = 40.0, 0.02, 1000.0
VISCOSITY_M2_S = 1.0e-6
VELOCITY_M_S = 0.05
HEAD_M = 20.0
EVENT_TIME_S, CLOSING_TIME_S = 0.01, 0.002
#: The decay is measured over this many periods from :data:`FIRST_WINDOW_S`.
WINDOWS, FIRST_WINDOW_S = 12, 0.3
REACHES = (20, 40, 80, 160)


def propagation(s: complex, radius_m: float, *, steady: bool = True, wave_speed_m_s: float = WAVE_SPEED_M_S,
                viscosity_m2_s: float = VISCOSITY_M2_S) -> complex:
    """Gamma(s), 1/m: eq. (L1), or (L2) with ``steady=False``."""
    k = 1j * radius_m * cmath.sqrt(s / viscosity_m2_s)
    # J1 / J0 from the exponentially scaled functions (the same factor exp(-|Im k|) on both): no overflow when the
    # Stokes layer is thin (|k| in the thousands)
    ratio = 1.0 / (1.0 - 2.0 * complex(jve(1, k)) / (k * complex(jve(0, k))))
    if not steady:
        ratio -= 8.0 * viscosity_m2_s / (radius_m ** 2 * s)
    return s / wave_speed_m_s * cmath.sqrt(ratio)


def fundamental(*, steady: bool = True, length_m: float = LENGTH_M, radius_m: float = DIAMETER_M / 2,
                wave_speed_m_s: float = WAVE_SPEED_M_S, viscosity_m2_s: float = VISCOSITY_M2_S) -> complex:
    """s_1 = -sigma + i omega (1/s) of eq. (L3), by the secant method from the frictionless mode."""
    target = 1j * math.pi / (2.0 * length_m)

    def residual(s):
        return propagation(s, radius_m, steady=steady, wave_speed_m_s=wave_speed_m_s,
                           viscosity_m2_s=viscosity_m2_s) - target

    s0 = 1j * math.pi * wave_speed_m_s / (2.0 * length_m)
    s1 = s0 * (1.0 + 1e-3) - 0.01
    f0, f1 = residual(s0), residual(s1)
    for _ in range(100):
        s0, f0, s1 = s1, f1, s1 - f1 * (s1 - s0) / (f1 - f0)
        f1 = residual(s1)
        if abs(s1 - s0) < 1e-13 * abs(s1):
            return s1
    raise RuntimeError(f"eq. (L3) did not converge (last step {abs(s1 - s0):.3g} 1/s): start nearer the mode")


def plant(friction_model: str, reaches: int, *, steady_loss: bool = True, t_end_s: float = 2.6) -> PlantConfig:
    """The laminar pipe with ``reaches`` MOC reaches and ``friction_model``; ``steady_loss=False``: Darcy f = 0."""
    area = math.pi * DIAMETER_M ** 2 / 4.0
    flow = VELOCITY_M_S * area
    f = 64.0 * VISCOSITY_M2_S / (VELOCITY_M_S * DIAMETER_M)
    net = HEAD_M - f * LENGTH_M / DIAMETER_M * VELOCITY_M_S ** 2 / (2.0 * G_M_S2)
    turbine = TurbineConfig(rated_head_m=net, rated_flow_m3_s=flow, rated_speed_rpm=1500.0,
                            rated_power_mw=RHO_WATER_KG_M3 * G_M_S2 * flow * net * 1e-6, runner_diameter_m=0.02,
                            opening_max=1.0, characteristics="ideal")
    segment = PenstockSegment(length_m=LENGTH_M, diameter_m=DIAMETER_M, wave_speed_m_s=WAVE_SPEED_M_S,
                              darcy_friction=f if steady_loss else 0.0)
    penstock = PenstockConfig(model="moc", static_head_m=HEAD_M, reaches=reaches, segments=(segment,),
                              friction_model=friction_model, column_separation="off")
    governor = GovernorConfig(kp=2.0, ki=0.5, kd=0.0, derivative_filter_s=0.0, permanent_droop=0.0, servo_time_s=0.2,
                              closing_time_s=10.0, opening_time_s=20.0)
    scenario = ScenarioConfig(kind="closure-law", t_end_s=t_end_s, initial_opening=1.0, event_time_s=EVENT_TIME_S,
                              closing_time_s=CLOSING_TIME_S)
    return PlantConfig(turbine=turbine, penstock=penstock, generator=GeneratorConfig(inertia_time_s=8.0),
                       governor=governor, scenario=scenario, solver=SolverConfig())


def decay(time_s, head_m, omega: float, *, first_s: float = FIRST_WINDOW_S, windows: int = WINDOWS):
    """``(sigma, omega)`` (1/s, rad/s) of the ringing head: its projection on exp(-i omega t) over each of
    ``windows`` periods 2 pi / ``omega`` from ``first_s``; sigma the slope of their log amplitude, omega corrected
    by their mean phase drift."""
    period = 2.0 * math.pi / omega
    h = np.asarray(head_m, float) - HEAD_M
    c = []
    for k in range(windows):
        on = (time_s >= first_s + k * period) & (time_s < first_s + (k + 1) * period)
        c.append(np.sum(h[on] * np.exp(-1j * omega * time_s[on])))
    c = np.array(c)  # window k: (A / 2) exp(i (omega_run - omega) k period) times a common factor
    if time_s[-1] < first_s + windows * period:
        raise ValueError(f"the run ends at {time_s[-1]:g} s, before the last window "
                         f"({first_s + windows * period:g} s): lengthen t_end_s")
    sigma = -np.polyfit(period * np.arange(windows), np.log(np.abs(c)), 1)[0]
    return float(sigma), float(omega + np.angle(c[1:] / c[:-1]).mean() / period)


def measure(friction_model: str, reaches: int, omega: float, *, steady_loss: bool = True, **windows):
    """``(sigma, omega)`` of one run (:func:`decay`)."""
    result = run_simulation(plant(friction_model, reaches, steady_loss=steady_loss))
    return decay(result.time_s, result.head_m, omega, **windows)


def table() -> list[dict]:
    """One row per model and grid: sigma and omega computed and exact."""
    exact = {True: fundamental(), False: fundamental(steady=False)}
    rows = []
    for label, model, steady_loss in (("convolution, no steady loss", "convolution", False),
                                      ("convolution + quadratic steady loss", "convolution", True),
                                      ("quasi-steady loss (quadratic)", "steady", True)):
        s = exact[steady_loss]
        for reaches in REACHES:
            result = run_simulation(plant(model, reaches, steady_loss=steady_loss))
            sigma, omega = decay(result.time_s, result.head_m, s.imag)
            late, _ = decay(result.time_s, result.head_m, s.imag, first_s=1.3, windows=6)  # the same run, later
            rows.append({"model": label, "reaches": reaches, "dt_ms": 1e3 * LENGTH_M / (WAVE_SPEED_M_S * reaches),
                         "sigma": sigma, "sigma_late": late, "omega": omega, "exact_sigma": -s.real,
                         "exact_omega": s.imag})
    return rows


def tsnet_rows(steps_s=(0.002, 0.001)) -> list[dict]:
    """TSNet (optional, ``pip install tsnet``) on the same case, its quasi-steady and its unsteady (Brunone) friction
    at each step of ``steps_s``: its reservoir-pipe-valve run of ``benchmarks/bench_tsnet_friction.py`` (the valve
    prescribing the flow, Q = Q0 s(t); EPANET's Darcy factor, 64 / Re in laminar flow), read as :func:`decay` reads
    hillsim's. ``sigma`` None where the run diverged (a head not finite)."""
    import importlib.metadata
    import tempfile

    from tests.scripts import load_script

    bench = load_script("bench_tsnet_friction")
    exact = fundamental()
    version = importlib.metadata.version("tsnet")
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for friction in ("steady", "unsteady"):
            for dt in steps_s:
                run = bench.run_tsnet(Path(folder), dt, friction, reservoir_head_m=HEAD_M, length_m=LENGTH_M,
                                      diameter_m=DIAMETER_M, wave_speed_m_s=WAVE_SPEED_M_S,
                                      flow_m3_s=VELOCITY_M_S * math.pi * DIAMETER_M ** 2 / 4.0,
                                      close_start_s=EVENT_TIME_S, close_time_s=CLOSING_TIME_S, t_end_s=2.6)
                finite = bool(np.all(np.isfinite(run["head_m"])))
                sigma, omega = decay(run["time_s"], run["head_m"], exact.imag) if finite else (None, None)
                rows.append({"model": f"TSNet {version}, {friction}", "dt_ms": 1e3 * dt, "sigma": sigma,
                             "omega": omega, "exact_sigma": -exact.real, "exact_omega": exact.imag,
                             "darcy_friction": run["darcy_friction"]})
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tsnet", action="store_true", help="also run TSNet on the case (pip install tsnet)")
    args = parser.parse_args(argv)
    with_steady, without = fundamental(), fundamental(steady=False)
    print(f"exact (L1): sigma {-with_steady.real:.4f} 1/s, omega {with_steady.imag:.4f} rad/s; without the steady "
          f"part (L2): sigma {-without.real:.4f} 1/s, omega {without.imag:.4f} rad/s; frictionless omega "
          f"{math.pi * WAVE_SPEED_M_S / (2 * LENGTH_M):.4f} rad/s; the quasi-steady laminar loss alone: sigma "
          f"16 nu / D^2 = {16 * VISCOSITY_M2_S / DIAMETER_M ** 2:.4f} 1/s\n")
    print("| model | reaches | dt (ms) | sigma (1/s), from 0.3 s | against exact | sigma from 1.3 s | omega (rad/s) "
          "| against exact |")
    print("|---|---|---|---|---|---|---|---|")
    for r in table():
        print(f"| {r['model']} | {r['reaches']} | {r['dt_ms']:.2f} | {r['sigma']:.4f} | "
              f"{100 * (r['sigma'] / r['exact_sigma'] - 1):+.2f} % | {r['sigma_late']:.4f} | {r['omega']:.4f} | "
              f"{100 * (r['omega'] / r['exact_omega'] - 1):+.3f} % |")
    if args.tsnet:
        print("\n| tool, friction | dt (ms) | sigma (1/s), from 0.3 s | against exact (L1) | omega (rad/s) | "
              "against exact |")
        print("|---|---|---|---|---|---|")
        for r in tsnet_rows():
            if r["sigma"] is None:
                print(f"| {r['model']} | {r['dt_ms']:.2f} | diverged | - | - | - |")
                continue
            print(f"| {r['model']} | {r['dt_ms']:.2f} | {r['sigma']:.4f} | "
                  f"{100 * (r['sigma'] / r['exact_sigma'] - 1):+.1f} % | {r['omega']:.3f} | "
                  f"{100 * (r['omega'] / r['exact_omega'] - 1):+.2f} % |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
