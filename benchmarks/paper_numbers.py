"""The papers' printed identification results put through hillsim's linear models.

Run: ``python benchmarks/paper_numbers.py`` (under a second). Prints the markdown tables of the docs section
"The papers' identified numbers through our models" (docs/identification.md); ``tests/test_docs.py`` checks that it
holds exactly this output, so the table cannot go stale.

Inputs (printed in the papers):

* paper 000 section 5.1: theta = [0.5061, 0.3950, -0.0512, 0.0319, 0.0434] of eq. (53) as printed (n_a = 3,
  n_b = 2, one sample delay), tau = 0.2 s; theta_h = [0.2855, 0.3225, 0.0843] of eq. (67); Tw = 0.0415;
* paper 000 section 5.2: {ex, eh, eu, eqx, eqh, equ} = {-0.1438, 0.1513, 0.1178, -0.0222, 0.0646, 0.0026};
* paper 002: ey 1.4948, e 0.0345, eqh 0.4910, Tw 1.886 s.
"""

from __future__ import annotations

import math

import numpy as np

from simulate.linear.models import ArxModel, LinearPlant, arma_coefficients, torque_transfer_function

TAU_S = 0.2
THETA_000 = (0.5061, 0.3950, -0.0512, 0.0319, 0.0434)
THETA_H_000 = (0.2855, 0.3225, 0.0843)
TW_000_S = 0.0415
SIX_000 = {"ex": -0.1438, "ey": 0.1178, "eh": 0.1513, "eqx": -0.0222, "eqy": 0.0026, "eqh": 0.0646}
PAPER_002 = {"ey": 1.4948, "e": 0.0345, "eqh": 0.4910, "water_time_s": 1.886}


def _g(v: float, digits: int = 4) -> str:
    return f"{v:.{digits}g}"


def _poles(coefficients) -> np.ndarray:
    """Roots of z^n - a1 z^(n-1) - ... - an."""
    return np.roots(np.r_[1.0, -np.asarray(coefficients, dtype=float)])


def _pole_text(z: complex) -> str:
    s = np.log(complex(z)) / TAU_S
    zt = f"{z.real:.4f}" if abs(z.imag) < 1e-12 else f"{z.real:.4f}{z.imag:+.4f}j"
    if abs(z.imag) < 1e-12 and z.real < 0:
        return f"{zt} (negative real: no continuous-time equivalent)"
    return f"{zt} (s = {s.real:.3f} 1/s, time constant {-1.0 / s.real:.3g} s)"


def paper_000() -> tuple[str, dict]:
    arx = ArxModel.from_theta(THETA_000, n_a=3, n_b=2, input_delay=1, sample_time_s=TAU_S)
    poles = _poles(arx.a)
    dc_arx = float(arx.b.sum() / (1.0 - arx.a.sum()))
    step = arx.step_response(150)
    slow = max(poles.real[np.abs(poles.imag) < 1e-12])
    s_slow = math.log(slow) / TAU_S
    # the six coefficients with rigid water (paper 000 eqs. 10-12, Tw = 0.0415) and no grid damping: its static
    # speed gain does not depend on J; J chosen so that the slow pole equals the ARX's slowest pole
    j_fit = SIX_000["ex"] / s_slow * 1.0  # rigid, Tw -> 0: pole ~ ex / J
    for _ in range(50):  # refine: slowest root of D2 = s_slow
        plant = LinearPlant(**SIX_000, water_time_s=TW_000_S, inertia_time_s=j_fit)
        roots = np.roots(plant.speed_transfer_function()[1])
        j_fit *= float(max(roots.real)) / s_slow
    plant = LinearPlant(**SIX_000, water_time_s=TW_000_S, inertia_time_s=j_fit)
    num, den = plant.speed_transfer_function()
    dc_six = float(num[-1] / den[-1])
    step_six = plant.step_response(TAU_S, 150)[:, 0]
    # the ARX has one sample of delay: compare its step (starts at k = 2) with the ZOH step of the six-coefficient
    # model (starts at k = 1) as printed, i.e. the models as the paper would use them
    diff = float(np.max(np.abs(step - step_six)) / np.max(np.abs(step_six)))
    eh_implied = 1.0 - SIX_000["ex"] / 2.0
    eqh_implied = 0.5 - SIX_000["eqx"] / 2.0
    head_poles = _poles(THETA_H_000[:2])
    rows = [
        ("speed ARX eq. (53), theta", ", ".join(str(v) for v in THETA_000)),
        ("its poles (z, tau = 0.2 s)", "; ".join(_pole_text(z) for z in sorted(poles, key=lambda z: -z.real))),
        ("its DC gain x/u", _g(dc_arx)),
        ("its step response at 1, 5, 30 s (per unit opening)",
         f"{step[5]:.4f}, {step[25]:.4f}, {step[150]:.4f}"),
        ("six coefficients (sect. 5.2), rigid water Tw = 0.0415, no grid damping: DC gain x/u = ey/(-ex) "
         "(the head returns to 0)",
         f"{dc_six:.4f} (vs {dc_arx:.4f} from theta: the two printed models disagree by "
         f"{abs(dc_six / dc_arx - 1):.0%})"),
        ("J that puts the six-coefficient model's slow pole on the ARX's", f"{j_fit:.4g} s"),
        ("step response difference, six-coefficient model vs ARX", f"{diff:.0%} of the peak"),
        ("implied eh = 1 - ex/2 (unit-quantity scaling, what our linearization of a hill chart gives)",
         f"{eh_implied:.4f} vs printed {SIX_000['eh']}"),
        ("implied eqh = 1/2 - eqx/2", f"{eqh_implied:.4f} vs printed {SIX_000['eqh']}"),
        ("head ARX eq. (67), theta_h", ", ".join(str(v) for v in THETA_H_000)
         + f"; poles {', '.join(f'{z.real:.4f}' for z in head_poles)}; eq. (68): c_h Tw = "
           f"{THETA_H_000[2] * TW_000_S:.4f} (printed 0.0035)"),
    ]
    lines = ["| Wang et al. (2023) | through our models |", "|---|---|"] + [f"| {a} | {b} |" for a, b in rows]
    return "\n".join(lines), {"dc_arx": dc_arx, "dc_six": dc_six, "j_fit": j_fit, "step_difference": diff,
                              "poles": poles, "eh_implied": eh_implied, "eqh_implied": eqh_implied}


def paper_002() -> tuple[str, dict]:
    p = PAPER_002
    num, den = torque_transfer_function(ey=p["ey"], e=p["e"], eqh=p["eqh"], water_time_s=p["water_time_s"])
    zero = float(np.roots(num)[0])
    pole = float(np.roots(den)[0])
    initial = float(num[0] / den[0])  # s -> infinity: the instant torque change of an opening step
    # what e means for the other coefficients: e = eqy eh / ey - eqh (paper 002 under eq. (1))
    eqy_eh = p["ey"] * (p["e"] + p["eqh"])
    eqx_implied = 1.0 - 2.0 * p["eqh"]  # eqh = 1/2 - eqx/2
    ideal_e = 1.0 * 1.5 / 1.0 - 0.5
    a, b, c = arma_coefficients(ey=p["ey"], e=p["e"], eqh=p["eqh"], water_time_s=p["water_time_s"],
                                sample_time_s=TAU_S)
    t = np.array([0.0, 1.0, 5.0])
    # step response of G_t = ey (1 - e Tw s) / (1 + eqh Tw s): ey - ey (1 + e/eqh) exp(-t / (eqh Tw))
    step = p["ey"] - p["ey"] * (1.0 + p["e"] / p["eqh"]) * np.exp(-t / (p["eqh"] * p["water_time_s"]))
    rows = [
        ("printed ey, e, eqh, Tw", f"{p['ey']}, {p['e']}, {p['eqh']}, {p['water_time_s']} s"),
        ("torque G_t = ey (1 - e Tw s)/(1 + eqh Tw s): pole, zero",
         f"{pole:.4f} 1/s (time constant eqh Tw = {p['eqh'] * p['water_time_s']:.3f} s); zero +{zero:.2f} 1/s "
         f"(right half plane)"),
        ("DC gain, initial value (water hammer) of an opening step",
         f"{p['ey']}; {initial:.4f} (= -ey e / eqh)"),
        ("step response at 0, 1, 5 s", ", ".join(f"{v:.4f}" for v in step)),
        ("ARMA eq. (7)-(8) at Dt = 0.2 s: a, b, c", f"{a:.4f}, {b:.4f}, {c:.4f}"),
        ("e against the ideal turbine (ex -1, ey 1, eh 1.5, eqy 1, eqh 0.5 -> e = 1)",
         f"{p['e']} vs {ideal_e:.1f}: almost no non-minimum-phase dip"),
        ("implied eqy eh = ey (e + eqh)", f"{eqy_eh:.4f} (ideal 1.5)"),
        ("implied eqx from eqh = 1/2 - eqx/2", f"{eqx_implied:.4f}"),
    ]
    lines = ["| Wei et al. (2016) | through our models |", "|---|---|"] + [f"| {a} | {b} |" for a, b in rows]
    return "\n".join(lines), {"zero": zero, "pole": pole, "initial": initial, "eqy_eh": eqy_eh}


def markdown() -> str:
    """Both tables, as the identification page holds them (a generated block)."""
    return paper_000()[0] + "\n\n" + paper_002()[0] + "\n"


if __name__ == "__main__":
    print(markdown(), end="")
