"""Where the six coefficients' error in the measured region comes from: the fit's stops, the readings, the model.

For each turbine of the out-of-class family (:mod:`hillchart.synthetic.francis_variants`) the chart is drawn as
``benchmarks/bench_generalization.py`` draws it (8 opening lines of 6 unevenly spaced points, no runaway curve, seed
0), without reading noise and with 0.3 %, and nets are trained (``hillsim train``'s defaults, ensemble of 10) four
ways:

* ``defaults``: every sample the extension makes; the Levenberg-Marquardt stops chosen by the selection's
  cross-validation (the paper's or :data:`hillchart.nets.training.LONGER_STOPS`);
* ``the paper's stops``: the same samples, the stops of the paper's ``trainlm`` (goal 1e-5, 6 validation fails);
* ``longer fits``: the same samples, :data:`hillchart.nets.training.LONGER_STOPS` (goal 1e-7, 100 fails);
* ``measured samples alone``: no extension at all, the stops chosen as in the defaults.

Printed: the largest error of the six coefficients (nets minus exact turbine, over the three points of
:data:`hillchart.generalization.COEFFICIENT_POINTS`; the acceptance bound is 0.05) and the error of ``ex`` at the
rated point, per turbine and way, and how far the ensemble members' ``ex`` there scatter with the defaults.
``--physics`` also trains each turbine with its asymmetric incidence loss switched off (the model class's symmetric
loss).

Usage: ``PYTHONPATH=. python benchmarks/bench_coefficient_sources.py [--turbines slow-x,medium-x,fast-x]
[--noise 0,0.3] [--physics]`` (about 4 min on 2 cores; 8 min with ``--physics``).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from hillchart.extension.extend import ExtensionOptions, extend_samples  # noqa: E402
from hillchart.generalization import coefficient_errors, coefficient_points  # noqa: E402
from hillchart.io.samples import load_chart  # noqa: E402
from hillchart.linearize import six_coefficients  # noqa: E402
from hillchart.nets.training import LONGER_STOPS, PAPER_STOPS, train_nets  # noqa: E402
from hillchart.synthetic.francis import DigitizationOptions, synthetic_chart_texts  # noqa: E402
from hillchart.synthetic.francis_variants import OUT_OF_CLASS_FAMILY  # noqa: E402

WAYS = ("defaults", "the paper's stops", "longer fits", "measured samples alone")
#: The stops given (``goal`` and ``max_fail`` of :class:`hillchart.nets.estimator.HillNet`) per way; none: chosen.
STOPS = {"the paper's stops": PAPER_STOPS, "longer fits": LONGER_STOPS}


def trained(chart, way: str, seed: int = 0):
    """Nets of ``chart`` trained one of the :data:`WAYS`."""
    if way == "measured samples alone":
        extended = extend_samples(chart, ExtensionOptions(runaway=False, zero_opening=False, zero_speed=False))
    else:
        extended = extend_samples(chart)
    return train_nets(extended, seed=seed, ensemble=10, **STOPS.get(way, {}))


def coefficient_row(member, noise_pct: float, seed: int = 0, ways=WAYS) -> dict[str, tuple[float, float, float]]:
    """Way (of ``ways``) -> (largest six-coefficient error, ex error at the rated point, standard deviation of the
    ensemble members' ex there) for one family member's chart."""
    options = DigitizationOptions(points_per_line=6, spacing="uneven", noise_pct=noise_pct, q11_unit="l/s",
                                  efficiency_unit="percent", opening_lines=8, runaway=False)
    texts = synthetic_chart_texts(seed=seed, turbine=member, options=options)
    with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, text in texts.items():
            (Path(folder) / name).write_text(text, encoding="utf-8")
        chart = load_chart(folder)
        exact = member.turbine()
        scale = float(chart.info.opening_max) / exact.opening_max
        n11, a_mm = coefficient_points(exact)["rated"]
        exact_ex = six_coefficients(exact, n11=n11, opening=a_mm).ex
        row = {}
        for name in ways:
            nets = trained(chart, name, seed)
            ex = six_coefficients(nets, n11=n11, opening=a_mm * scale).ex - exact_ex
            spread = np.std([six_coefficients(m, n11=n11, opening=a_mm * scale).ex for m in nets.members()])
            row[name] = (max(coefficient_errors(nets, exact, scale).values()), float(ex), float(spread))
    return row


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--turbines", default=",".join(OUT_OF_CLASS_FAMILY))
    parser.add_argument("--noise", default="0,0.3")
    parser.add_argument("--physics", action="store_true",
                        help="also with the asymmetric incidence loss switched off")
    args = parser.parse_args(argv)
    print("Largest six-coefficient error / ex error at rated (nets - exact; bound 0.05), seed 0, no runaway curve; "
          "the standard deviation of the members' ex at rated with the defaults\n")
    print("| turbine | noise % | " + " | ".join(WAYS) + " | members' ex, sd |")
    print("|---|---|" + "---|" * (len(WAYS) + 1))
    for name in args.turbines.split(","):
        member = OUT_OF_CLASS_FAMILY[name]
        members = {name: member}
        if args.physics:
            symmetric = dataclasses.replace(member.physics, k_incidence_negative=member.params.k_incidence)
            members[f"{name}, symmetric incidence loss"] = dataclasses.replace(member, physics=symmetric)
        for label, variant in members.items():
            for noise in (float(v) for v in args.noise.split(",")):
                row = coefficient_row(variant, noise)
                cells = " | ".join(f"{row[s][0]:.3f} / {row[s][1]:+.3f}" for s in WAYS)
                print(f"| {label} | {noise:g} | {cells} | {row['defaults'][2]:.3f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
