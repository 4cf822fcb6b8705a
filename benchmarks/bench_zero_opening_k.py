"""Zero-opening K of eq. (8) against the truth on the synthetic family, and how much of it the chart decides.

    PYTHONPATH=. python benchmarks/bench_zero_opening_k.py      (about 15 s: the turbine-model fit only, no nets)

Part 1: K / true for the 36 charts of ``bench_generalization.py`` (3 turbines x noise 0.15 / 0.3 % x seeds 0-2 x
with / without runaway curve; 8 opening lines of 6 uneven points, l/s, percent), from
:func:`hillchart.extension.extend.extend_samples` with default options. Part 2: the same fit on the fast turbine's
seed-0 chart with the prior's median disc-friction share and width changed (``hillchart.extension.turbine_model``):
when K follows the prior one to one, the chart does not identify it.
"""

from __future__ import annotations

import tempfile
import warnings
from pathlib import Path

import hillchart.extension.turbine_model as turbine_model
from hillchart.extension.extend import extend_samples
from hillchart.io.samples import load_chart
from hillchart.synthetic.francis import FAMILY, DigitizationOptions, synthetic_chart_texts


def _chart(name: str, seed: int, noise: float, runaway: bool):
    options = DigitizationOptions(points_per_line=6, spacing="uneven", noise_pct=noise, q11_unit="l/s",
                                  efficiency_unit="percent", opening_lines=8, runaway=runaway)
    with tempfile.TemporaryDirectory() as folder:
        for file, text in synthetic_chart_texts(seed=seed, turbine=name, options=options).items():
            (Path(folder) / file).write_text(text, encoding="utf-8")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "runaway.csv is absent": intended here
            return load_chart(folder)


def k_ratio(name: str, chart) -> float:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return extend_samples(chart).k_zero_opening / FAMILY[name].turbine().params.k_disc_friction


def main() -> None:
    print("| turbine | K / true, each chart (noise 0.15 then 0.3; seeds 0-2; runaway with, without) | range |")
    print("|---|---|---|")
    for name in ("slow", "medium", "fast"):
        ratios = [k_ratio(name, _chart(name, seed, noise, runaway))
                  for noise in (0.15, 0.3) for seed in (0, 1, 2) for runaway in (True, False)]
        print(f"| {name} | {' '.join(f'{r:.2f}' for r in ratios)} | {min(ratios):.2f}-{max(ratios):.2f} |")
    chart = _chart("fast", 0, 0.3, True)
    share, log_sd = turbine_model.DISC_FRICTION_SHARE, turbine_model.DISC_FRICTION_LOG_SD
    print("\nfast turbine, seed 0, noise 0.3 %, runaway curve: K / true against the prior")
    try:
        for median in (0.0025, 0.005, 0.01):
            turbine_model.DISC_FRICTION_SHARE = median
            print(f"  prior median share {100 * median:.2g} %: K / true {k_ratio('fast', chart):.2f}")
        turbine_model.DISC_FRICTION_SHARE = share
        for factor in (5.0, 20.0, 1000.0):
            turbine_model.DISC_FRICTION_LOG_SD = __import__("math").log(factor)
            print(f"  prior width factor {factor:g} (median 1 %): K / true {k_ratio('fast', chart):.2f}")
    finally:
        turbine_model.DISC_FRICTION_SHARE, turbine_model.DISC_FRICTION_LOG_SD = share, log_sd


if __name__ == "__main__":
    main()
