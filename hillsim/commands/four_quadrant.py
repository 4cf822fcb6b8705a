"""``hillsim four-quadrant TABLE_DIR --out nets.json``: the Suter-curve nets of a pump-turbine's complete
characteristics, as the simulator runs them."""

from __future__ import annotations

import argparse
import time

from hillsim.commands import SEED_RANGE, int_in

#: Allowed ``--hidden`` sizes and ``--members`` counts.
HIDDEN_RANGE = (2, 60)
MEMBERS_RANGE = (1, 20)
#: The defaults: the shipped nets' (:data:`hillchart.four_quadrant.nets.SHIPPED`, which a test holds them to; not
#: imported here, where every command's options are declared at start-up).
SHIPPED = {"hidden": 20, "members": 4, "seed": 0}


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "four-quadrant",
        help="pump-turbine complete characteristics -> the Suter-curve nets WH, WM the simulator runs (nets.json)",
        description="Read a complete-characteristics folder (table.toml, table.csv: opening, N11, Q11, M11 of each "
                    "opening line over the four quadrants at unit head), make its Suter curves with the improved "
                    "transform and train the nets WH(x, y) and WM(x, y) (one logsig hidden layer on cos x, sin x "
                    "and the opening; Levenberg-Marquardt), with an ensemble whose band is calibrated on the "
                    "table's own lines: nets of every other line, then of the others, say how far the curves lie "
                    "from the point nets between measured lines. A plant's turbine.characteristics names the file. "
                    "Every check runs before anything is written.",
    )
    parser.add_argument("table", metavar="TABLE_DIR",
                        help="complete-characteristics folder (table.toml with name, opening_unit, opening_max, "
                             "q11_unit and the rated point rated_n11_rpm, rated_q11, rated_m11_nm; table.csv)")
    parser.add_argument("--out", required=True, help="nets.json to write")
    parser.add_argument("--hidden", type=int, default=SHIPPED["hidden"],
                        help=f"hidden logsig neurons per net, {HIDDEN_RANGE[0]}-{HIDDEN_RANGE[1]} (default "
                             f"{SHIPPED['hidden']})")
    parser.add_argument("--members", type=int, default=SHIPPED["members"],
                        help=f"ensemble members, the point nets included, {MEMBERS_RANGE[0]}-{MEMBERS_RANGE[1]} "
                             f"(default {SHIPPED['members']}; 1: no band)")
    parser.add_argument("--seed", type=int, default=SHIPPED["seed"],
                        help="seed of the splits and initialisations (default 0)")
    parser.add_argument("--no-calibration", action="store_true",
                        help="keep the members' training spread as the band instead of calibrating it on the "
                             "table's own lines (one training instead of three)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from hillchart.four_quadrant.nets import PUMP_TURBINE_CONSTANTS, curve_errors, table_nets
    from hillchart.four_quadrant.table import load_complete_characteristics

    for name, value, bounds in (("--hidden", args.hidden, HIDDEN_RANGE), ("--members", args.members, MEMBERS_RANGE),
                                ("--seed", args.seed, SEED_RANGE)):
        int_in(name, value, *bounds)
    out = args.outputs.file("--out", args.out)  # checked now, renamed into place when everything succeeded
    table = load_complete_characteristics(args.table)
    args.outputs.check_reads()  # --out one of the table's files: refused before training, not after
    start = time.perf_counter()
    nets = table_nets(table, hidden=args.hidden, members=args.members, seed=args.seed,
                      calibrate=False if args.no_calibration else None)
    elapsed = time.perf_counter() - start
    nets.save(out)
    samples = table.suter(PUMP_TURBINE_CONSTANTS)
    lines = sorted(set(table.opening.tolist()))
    fit = curve_errors(nets, samples)
    print(f"table {table.name!r}: {len(lines)} opening lines ({lines[0]:g}-{lines[-1]:g} {table.opening_unit}), "
          f"{table.opening.size} points; rated N11 {table.rated['n11_rpm']:.4g} r/min, Q11 "
          f"{table.rated['q11_m3_s']:.4g} m^3/s, M11 {table.rated['m11_nm']:.4g} N*m")
    print(f"nets: 3-{args.hidden}-1, {args.members} member(s); at the table's points WH {fit['wh']['rms_pct']:.2f} % "
          f"and WM {fit['wm']['rms_pct']:.2f} % RMS of their range (worst {fit['wh']['max_pct']:.2f} and "
          f"{fit['wm']['max_pct']:.2f} %)")
    band = nets.training.get("band", {})
    if band.get("calibrated"):
        print(f"band: calibrated on the table's own lines (every other line held out): the members stand "
              f"{band['wh']:.2f} (WH) and {band['wm']:.2f} (WM) times as far from the point nets as trained; their "
              f"own band covered {100 * band['coverage_before']['wh']:.0f} and "
              f"{100 * band['coverage_before']['wm']:.0f} % of the held-out curves")
    elif args.members > 1:
        why = band.get("why", "--no-calibration")
        print(f"warning: band not calibrated ({why}): it is the members' training spread, not the nets' error "
              "between measured lines; give four opening lines or more, without --no-calibration")
    print(f"training time: {elapsed:.1f} s")
    print(f"wrote {args.out}")
    return 0
