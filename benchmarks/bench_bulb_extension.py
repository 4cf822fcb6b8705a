"""Nets from a double-regulated test table, with and without the physical-model extension, against the exact bulb.

For each table of the synthetic bulb (``hillsim synth --turbine bulb``: a water-system table, N11 on one curve near
the plant's; a best-efficiency table, one N11 per setting at 73-126 r/min; propeller curves, 60 settings each at
N11 120-200 r/min; 0.3 % noise; seeds as given), and
of two other synthetic bulbs (``--bulbs``: geometry, closed vane and losses changed; :data:`BULBS`), the
three-input nets are trained as ``hillsim fccm --simulator-nets`` does, on the table alone (3-15-1, the default with
``--no-extension``) and with the extension (3-30-1, the default), and measured against the exact bulb:

* the table region: RMS error of Q11 and M11 at the table's own settings, % of the table's range;
* where a load rejection goes: 300 seeded settings over the paper's ranges, N11 from 140 r/min (the example plant's
  rated N11) up to each setting's true runaway: RMS and worst M11 error, % of the table's M11 range;
* the runaway N11 of the nets at 40 of those settings against the truth (median and worst relative error; "none"
  where the nets' torque stays positive up to twice the true runaway);
* for the water-system and propeller-curve tables, the 60 s load rejection of ``data_synthetic/plant_bulb.toml`` on
  the nets against the exact bulb (on its own cam), with the blades fixed at -7 deg, on the nets' cam
  (``combinator.relation = "cam"``) and on the cam of the fitted model the extended nets carry (``"model"``): the
  change of the max speed rise (points) and of the max head and the min runner-outlet pressure head (% of the
  initial head).

Run:  PYTHONPATH=$PWD python benchmarks/bench_bulb_extension.py [--seeds 1] [--restarts 2] [--bulbs default,A,B]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

from data_synthetic import PLANT_BULB
from hillchart.errors import InputError, NumericalError
from hillchart.fccm.double_regulated import table_unit_samples, train_table_nets
from hillchart.fccm.table import load_test_table
from hillchart.synthetic.bulb import BulbParameters, SyntheticBulb, write_bulb_table
from simulate.config import load_plant
from simulate.loop.engine import run_simulation

#: Hidden neurons of the extended nets, as hillsim fccm --simulator-nets trains them.
EXTENDED_HIDDEN = 30
TABLES = (("water-system", 150), ("best-efficiency", 300), ("propeller-curves", 300))
#: The synthetic bulb and two others the extension was not developed on (geometry, closed vane and losses changed).
BULBS = {"default": {},
         "A": dict(hub_ratio=0.45, swirl_factor=0.25, guide_vane_closed_deg=33.0, beta1_deg=30.0, beta2_deg=24.0,
                   k_incidence=0.5, k_swirl=0.4, k_disc_friction=8e-4),
         "B": dict(hub_ratio=0.35, swirl_factor=0.4, guide_vane_closed_deg=36.0, beta1_deg=26.0, beta2_deg=20.0,
                   k_runner=0.05, k_draft_tube=0.2, k_guide_vane=0.05)}


def rejection_region(truth, count: int = 300, seed: int = 1):
    """Settings over the paper's ranges and N11 from 140 r/min to each setting's true runaway."""
    rng = np.random.default_rng(seed)
    gv = rng.uniform(truth.params.guide_vane_closed_deg + 0.3, 78.0, count)
    blade = rng.uniform(-18.0, 16.0, count)
    runaway = np.array([brentq(lambda n: float(truth.m11(n, g, b)), 20.0, 3000.0) for g, b in zip(gv, blade)])
    return 140.0 + rng.uniform(0.0, 1.0, count) * (runaway - 140.0), gv, blade, runaway


def unit_errors(nets, samples, truth) -> dict:
    measured = samples["origin"] == "measured"
    n, a, b = samples["n11"][measured], samples["opening"][measured], samples["blade_angle"][measured]
    q_range, m_range = np.ptp(samples["q11"][measured]), np.ptp(samples["m11"][measured])
    rms = lambda e, r: 100.0 * float(np.sqrt(np.mean(e ** 2))) / r  # noqa: E731
    n11, gv, blade, runaway = rejection_region(truth)
    dm = nets.m11(n11, gv, blade) - truth.m11(n11, gv, blade)
    ratios = []
    for g, bl, r in zip(gv[:40], blade[:40], runaway[:40]):
        try:
            ratios.append(brentq(lambda x: float(nets.m11(x, g, bl)), 50.0, 2.0 * r) / r - 1.0)
        except ValueError:  # no sign change: no runaway below twice the true one
            ratios.append(np.nan)
    ratios = np.abs(np.array(ratios))
    return {"table_q": rms(nets.q11(n, a, b) - truth.q11(n, a, b), q_range),
            "table_m": rms(nets.m11(n, a, b) - truth.m11(n, a, b), m_range),
            "rejection_m": rms(dm, m_range), "rejection_m_max": 100.0 * float(np.max(np.abs(dm))) / m_range,
            "runaway_median": 100.0 * float(np.nanmedian(ratios)) if np.isfinite(ratios).any() else np.nan,
            "runaway_max": 100.0 * float(np.nanmax(ratios)) if np.isfinite(ratios).any() else np.nan,
            "runaway_none": int(np.isnan(ratios).sum())}


def rejection(nets_path: Path, over: dict) -> str:
    truth_over = {k: v for k, v in over.items() if (k, v) != ("combinator.relation", "model")}  # the truth's own cam
    exact = run_simulation(load_plant(PLANT_BULB, {**truth_over,
                                                   "turbine.characteristics": "synthetic-bulb"})).summary()
    try:
        run = run_simulation(load_plant(PLANT_BULB, {**over, "turbine.characteristics": str(nets_path)}),
                             raise_on_failure=False).summary()
    except (InputError, NumericalError) as exc:  # e.g. no cam: the nets' flow is <= 0 on the cam's scan
        return f"refused ({str(exc)[:60]}...)"
    if not run["success"]:
        return f"fails at {run['t_end_s']:.2f} s"
    head = exact["initial_head_m"]
    return (f"speed {100 * (run['max_speed_rise'] - exact['max_speed_rise']):+.2f} pt, max head "
            f"{100 * (run['max_head_m'] - exact['max_head_m']) / head:+.2f} %, min outlet "
            f"{100 * (run['min_outlet_pressure_head_m'] - exact['min_outlet_pressure_head_m']) / head:+.2f} %")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=1, help="table seeds 0..N-1 (default 1)")
    parser.add_argument("--restarts", type=int, default=2, help="LM initialisations per net (default 2)")
    parser.add_argument("--hidden", type=int, default=None,
                        help="hidden neurons of the extended nets (default: hillsim fccm's)")
    parser.add_argument("--tables", default=",".join(c for c, _ in TABLES),
                        help=f"comma-separated table kinds among {', '.join(c for c, _ in TABLES)} (default: all)")
    parser.add_argument("--bulbs", default="default", help="comma-separated synthetic bulbs among "
                        f"{', '.join(BULBS)} (default: default; the rejections only for the default bulb, whose "
                        "plant the example is)")
    args = parser.parse_args(argv)
    bulbs = [b.strip() for b in args.bulbs.split(",")]
    unknown = [b for b in bulbs if b not in BULBS]
    if unknown:
        parser.error(f"--bulbs: unknown {unknown}; choose among {', '.join(BULBS)}")
    work = Path(tempfile.mkdtemp(prefix="bench_bulb_extension_"))
    print("| bulb | table | seed | nets | train s | table Q11 / M11 RMS % | rejection region M11 RMS / worst % | "
          "runaway N11 median / worst % (none) | rejection, blades fixed | rejection, the nets' cam | "
          "rejection, the fitted model's cam |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    kinds = [k.strip() for k in args.tables.split(",")]
    if any(k not in dict(TABLES) for k in kinds):
        parser.error(f"--tables: choose among {', '.join(c for c, _ in TABLES)}, got {args.tables!r}")
    tables = [(c, p) for c, p in TABLES if c in kinds]
    extended_hidden = EXTENDED_HIDDEN if args.hidden is None else args.hidden
    for bulb, closure, points, seed in ((b, c, p, s) for b in bulbs for c, p in tables for s in range(args.seeds)):
        truth = SyntheticBulb(BulbParameters(**BULBS[bulb]))
        folder = work / f"{bulb}_{closure}_{seed}"
        write_bulb_table(folder, n_points=points, closure=closure, seed=seed, turbine=truth)
        table = load_test_table(folder)
        for name, extension, hidden in (("table only 3-15-1", False, 15),
                                        (f"extended 3-{extended_hidden}-1", True, extended_hidden)):
            t0 = time.perf_counter()
            samples, _, model = table_unit_samples(table, extension=extension, seed=seed)
            nets, _ = train_table_nets(samples, hidden=hidden, restarts=args.restarts, members=1, seed=seed,
                                       model=model)
            seconds = time.perf_counter() - t0
            path = nets.save(folder / f"nets_{extension}.json")
            e = unit_errors(nets, samples, truth)
            fixed = cam = model_cam = "-"
            if closure != "best-efficiency" and bulb == "default":  # the example plant is the default bulb's (N11 150)
                fixed = rejection(path, {"combinator.relation": "off", "combinator.fixed_angle_deg": -7.0})
                cam = rejection(path, {})
                if extension:
                    model_cam = rejection(path, {"combinator.relation": "model"})
            print(f"| {bulb} | {closure} ({points}) | {seed} | {name} | {seconds:.0f} | {e['table_q']:.2f} / "
                  f"{e['table_m']:.2f} | {e['rejection_m']:.1f} / {e['rejection_m_max']:.1f} | "
                  f"{e['runaway_median']:.1f} / {e['runaway_max']:.1f} ({e['runaway_none']}) | {fixed} | {cam} | "
                  f"{model_cam} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
