"""Error of each extended-sample family against the synthetic turbine's exact values.

Run: ``python benchmarks/bench_extension.py`` (about 3 s). Prints, per target and origin, the number of samples and
the RMS / max absolute error against the truth, also as a percentage of the truth's range over the whole chart
domain (N11 0..1.15 x runaway, opening 0..max), plus K of eq. (8) fitted vs the true disc-friction constant.
"""

from __future__ import annotations

import time

import numpy as np

from data_synthetic import FRANCIS_DIR
from hillchart.extension.extend import ORIGINS, TARGETS, extend_samples
from hillchart.io.samples import load_chart
from hillchart.synthetic.francis import SyntheticFrancis


def table(extended=None) -> str:
    """The markdown table of each boundary family's error against the exact turbine, and K of eq. (8)."""
    turbine = SyntheticFrancis()
    if extended is None:
        extended = extend_samples(load_chart(FRANCIS_DIR))
    truth = np.loadtxt(FRANCIS_DIR / "truth.csv", delimiter=",", skiprows=1)
    spans = {"q11": np.ptp(truth[:, 2]), "m11": np.ptp(truth[:, 3])}
    units = {"q11": "m3/s", "m11": "N*m"}
    lines = ["| target | origin | samples | RMS error | max error | max / truth range |", "|---|---|---|---|---|---|"]
    for target in TARGETS:
        x, y, origin = extended.select(target)
        exact = (turbine.q11 if target == "q11" else turbine.m11)(x[:, 0], x[:, 1])
        for o in ORIGINS:
            m = origin == o
            if not m.any():
                continue
            err = y[m] - exact[m]
            lines.append(
                f"| {target} | {o} | {int(m.sum())} | {np.sqrt(np.mean(err**2)):.4g} {units[target]} | "
                f"{np.abs(err).max():.4g} {units[target]} | {100 * np.abs(err).max() / spans[target]:.2f} % |"
            )
    lines += ["", f"K (eq. 8): fitted {extended.k_zero_opening:.4g}, true {turbine.params.k_disc_friction:.4g} "
                  f"N*m/(r/min)^2"]
    return "\n".join(lines)


def main() -> None:
    t0 = time.perf_counter()
    extended = extend_samples(load_chart(FRANCIS_DIR))
    elapsed = time.perf_counter() - t0
    print(f"load + extend: {elapsed:.2f} s; efficiency surface degree {extended.efficiency_surface.degree}")
    print(table(extended))


if __name__ == "__main__":
    main()
