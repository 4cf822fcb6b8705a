"""Figures of an identification report (PNG): series, six coefficients, step responses, theta convergence,
simulation mode. matplotlib is imported only here, when a report is written."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hillchart.linearize import COEFFICIENT_NAMES


def plot_report(report, out_dir) -> dict[str, Path]:
    """The figures of ``report`` (a :class:`simulate.identification.compare.IdentificationReport`) as PNG files in
    ``out_dir``; returns ``{key: path}`` (``series_png``, ``six_png``, ``step_png``, ``theta_png``,
    ``simulation_mode_png``; a figure without data is left out)."""
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

    six = summ.six_coefficients
    fig, ax = plt.subplots(figsize=(8, 4))
    groups = [k for k in ("exact", "nets", "batch_ls") if getattr(six, k) is not None]
    width = 0.8 / len(groups)
    pos = np.arange(6)
    for i, g in enumerate(groups):
        values = getattr(six, g).values()  # in COEFFICIENT_NAMES order
        ax.bar(pos + (i - (len(groups) - 1) / 2) * width, values, width,
               label={"exact": "exact turbine", "nets": "nets (analytic)", "batch_ls": "batch LS (eqs. 69-70)"}[g])
    ax.set_xticks(pos, COEFFICIENT_NAMES)
    ax.axhline(0, color="k", lw=0.5)
    ax.legend()
    ax.set_title("six coefficients")
    fig.tight_layout()
    paths["six_png"] = out / "six_coefficients.png"
    fig.savefig(paths["six_png"], dpi=100)
    plt.close(fig)

    steps = report.traces.step_responses
    if steps.curves():
        fig, ax = plt.subplots(figsize=(8, 4.5))
        for label, values in steps.curves().items():
            ax.plot(steps.time_s, values, lw=2.4 if label == "nets_zoh" else 1.2,
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

    hist = report.traces.histories
    if hist:
        names = list(hist)
        p = hist[names[0]].shape[1]
        fig, axes = plt.subplots(p, 1, sharex=True, figsize=(9, 1.6 * p + 1))
        k0 = report.traces.simulation_mode.start
        t = s.time_s[k0 + 1: k0 + 1 + hist[names[0]].shape[0]]
        ref = summ.arx.nets_zoh.theta if summ.arx.nets_zoh is not None else None
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
            quiet = summ.experiment.quiet_s
            if quiet and len(t):
                ax.axvspan(t[-1] - quiet, t[-1], color="0.9", zorder=0)
        np.atleast_1d(axes)[0].legend(fontsize=7, ncol=4)
        np.atleast_1d(axes)[-1].set_xlabel("time (s)")
        fig.suptitle("theta_hat(k): RLS, RLS with forgetting, dead-zone RLS (noise level "
                     f"{summ.experiment.noise_level}; grey: quiet tail, constant opening)")
        fig.tight_layout()
        paths["theta_png"] = out / "theta_convergence.png"
        fig.savefig(paths["theta_png"], dpi=100)
        plt.close(fig)

    sim = report.traces.simulation_mode.x_hat
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
        fig.suptitle("simulation mode (Wang et al. 2023, eqs. 62-64), final theta")
        fig.tight_layout()
        paths["simulation_mode_png"] = out / "simulation_mode.png"
        fig.savefig(paths["simulation_mode_png"], dpi=100)
        plt.close(fig)
    return paths


