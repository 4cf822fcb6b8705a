"""Markdown tables of an identification summary (what ``hillsim identify`` prints).

An ARX model the review marked unstable (:attr:`ArxEstimate.stable` False) shows ``unstable`` instead of its step
and simulation-mode errors, and numbers beyond :data:`PLAIN_LIMIT` are written in scientific notation (a diverging
response is not printed as 33282684472264249835520.0000).
"""

from __future__ import annotations

import math

from hillchart.linearize import COEFFICIENT_NAMES
from simulate.identification.results import ArmaFit, DivergedSimulationMode, IdentificationSummary

#: Numbers printed plainly up to this magnitude; larger ones (a diverging response) in scientific notation.
PLAIN_LIMIT = 1e6


def _fmt(value, digits=4, none="-") -> str:
    if value is None:
        return none
    if isinstance(value, str):  # already worded by the caller (e.g. "unstable")
        return value
    if isinstance(value, bool):
        return "PASS" if value else "FAIL"
    if isinstance(value, float) and not math.isfinite(value):
        return "nan"
    if abs(value) >= PLAIN_LIMIT:
        return f"{value:.3e}"
    return f"{value:.{digits}f}" if abs(value) >= 1e-3 or value == 0 else f"{value:.3e}"


def markdown_tables(summary: IdentificationSummary) -> str:
    """The comparison as markdown tables (six coefficients, ARX theta side by side, responses, order sweep, paper
    002, acceptance)."""
    lines = []
    six = summary.six_coefficients
    cols = [k for k in ("exact", "nets", "batch_ls") if getattr(six, k) is not None]
    head = {"exact": "exact turbine", "nets": "nets (analytic)", "batch_ls": "batch LS (eqs. 69-70)"}
    extra = six.nets is not None
    lines.append("| coefficient | " + " | ".join(head[c] for c in cols) + (" | batch LS - nets |" if extra else " |"))
    lines.append("|---" * (len(cols) + 1 + int(extra)) + "|")
    for k in COEFFICIENT_NAMES:
        row = [_fmt(getattr(getattr(six, c), k)) for c in cols]
        if extra:
            row.append(_fmt(getattr(six.batch_ls_minus_nets, k)))
        lines.append(f"| {k} | " + " | ".join(row) + " |")
    lines.append("")
    arx = summary.arx
    models = {"nets_zoh": arx.nets_zoh, "rls": arx.rls, "rls_forgetting": arx.rls_forgetting,
              "dead_zone_rls": arx.dead_zone_rls}
    names = [n for n, model in models.items() if model is not None]
    p = len(arx.rls.theta)
    st = summary.arx_structure
    labels = [f"a{i + 1}" for i in range(st.n_a)] + [f"b{j + 1}" for j in range(st.n_b)]
    title = {"nets_zoh": "ZOH of nets' model", "rls": "RLS", "rls_forgetting": f"RLS, lambda = "
             f"{arx.forgetting_factor}", "dead_zone_rls": f"dead-zone RLS, eps0 = {arx.dead_zone_eps0:.2g}"}
    lines.append("| theta | " + " | ".join(title[n] for n in names) + " |")
    lines.append("|---" * (len(names) + 1) + "|")
    for j in range(p):
        lines.append(f"| {labels[j]} | " + " | ".join(_fmt(models[n].theta[j]) for n in names) + " |")
    lines.append("")
    lines.append("| estimator | step response error vs nets (of peak) | simulation-mode max abs speed error (final "
                 "theta) | same, on-line theta(k) | theta spread in the quiet tail |")
    lines.append("|---|---|---|---|---|")
    for n, e in arx.estimates().items():
        unstable = e.stable is False
        online = e.simulation_mode_online
        step = "unstable" if unstable and e.step_error_vs_nets is not None else e.step_error_vs_nets
        final = "unstable" if unstable else e.simulation_mode_final_theta.max_abs_error
        lines.append(f"| {n} | {_fmt(step)} | {_fmt(final, 5)} | "
                     f"{'diverged' if isinstance(online, DivergedSimulationMode) else _fmt(online.max_abs_error, 5)} | "
                     f"{_fmt(e.theta_spread_quiet_tail)} |")
    if summary.simulated_step_vs_nets is not None:
        s = summary.simulated_step_vs_nets
        lines.append("")
        lines.append(f"Nonlinear simulator's first +{summary.experiment.step_amplitude:.0%} step vs the nets' "
                     f"linear prediction: max difference {_fmt(s.max_error_frac_of_peak)} of the peak "
                     f"(final value {_fmt(s.final_value_simulated)} vs {_fmt(s.final_value_nets)} per unit "
                     "step).")
    if summary.arx_order_sweep is not None:
        lines.append("")
        lines.append("| ARX order (batch LS, ZOH structure) | step error vs nets | step error vs the simulator's own "
                     "first step |")
        lines.append("|---|---|---|")
        for row in summary.arx_order_sweep:
            if row.unstable:
                lines.append(f"| {row.order} | unstable | unstable |")
            else:
                lines.append(f"| {row.order} | {_fmt(row.step_error_vs_nets)} | "
                             f"{_fmt(row.step_error_vs_simulated_step)} |")
    if isinstance(summary.arma_paper002, ArmaFit):
        a = summary.arma_paper002
        lines.append("")
        lines.append(f"| Wei et al. 2016 (Dt = {a.sample_time_s} s) | ARMA LS (eqs. 9-12, 8) | nets | nets with the "
                     "penstock friction folded in |")
        lines.append("|---|---|---|---|")
        for k in ("ey", "e", "eqh"):
            nets = getattr(a.nets, k) if a.nets is not None else None
            eff = getattr(a.nets_with_friction, k) if a.nets_with_friction is not None else None
            lines.append(f"| {k} | {_fmt(getattr(a, k))} | {_fmt(nets)} | {_fmt(eff)} |")
    if summary.acceptance is not None:
        lines.append("")
        lines.append("| acceptance check | result |")
        lines.append("|---|---|")
        for check in summary.acceptance.checks():
            lines.append(f"| {check.name} | {_fmt(check.passed, none=f'reported only ({check.reason})')} |")
        if summary.acceptance_note is not None:
            lines.append("")
            lines.append(f"Note: {summary.acceptance_note}.")
    return "\n".join(lines) + "\n"
