"""``hillsim fccm TABLE_DIR --inputs ... --outputs ... --out DIR``: full-characteristic net and paper 003's analyses."""

from __future__ import annotations

import argparse
from pathlib import Path


#: --simulator-nets: ensemble members (each trains both nets with every restart: the default 5 take about 9 s on a
#: real bulb rig's table of 285 rows on 2 cores, its model's fits included, and 20 several times that) and table
#: rows (a model test has some hundreds to a few thousand points; the Levenberg-Marquardt training's Jacobian grows
#: with the rows, and 200,000 rows ran for minutes).
MAX_MEMBERS = 20
MAX_SIMULATOR_NET_ROWS = 20_000


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "fccm",
        help="double-regulated turbine test table -> multi-output BP net, maps, image similarity, grey relations",
        description="Train one logsig BP net (Levenberg-Marquardt, 30/35/35 split, validation stop, hidden size "
                    "from eq. (3) with C chosen by validation) from a test-table folder (table.csv, table.toml) and "
                    "run the analyses of Wu et al.: efficiency maps over (Q11, n11) from interpolation and from the "
                    "net, their image similarity, the maps over the inputs, the operating characteristic and the "
                    "grey relational analysis of the controls.",
    )
    parser.add_argument("table", metavar="TABLE_DIR", help="test-table folder (table.csv + table.toml)")
    parser.add_argument("--inputs", default=None, help="comma-separated input columns, e.g. "
                        "blade_angle_deg,guide_vane_deg (required unless --simulator-nets)")
    parser.add_argument("--outputs", dest="output_columns", default=None, metavar="COLUMNS",
                        help="comma-separated output columns, e.g. efficiency,head_m,power_kw,flow_m3_s (required "
                             "unless --simulator-nets)")
    parser.add_argument("--simulator-nets", action="store_true",
                        help="instead: train the three-input nets Q11(n11, opening, blade angle) and M11 the "
                             "simulator runs (nets.json in --out), with an ensemble and plausibility checks; the "
                             "table needs guide_vane_deg, efficiency and n11/Q11 (or head, flow, speed and "
                             "diameter). An on-cam chart (blade_angle_deg without guide_vane_deg) gives two-input "
                             "nets over (n11, cam position) instead: vanes and blades move together")
    parser.add_argument("--closed-opening", type=float, default=None, metavar="DEG",
                        help="with --simulator-nets: the guide-vane angle at which the vanes touch (default: "
                             "fitted with the bulb model, or none with --no-extension). For an on-cam chart: the cam's "
                             "blade angle at which the flow stops (default: extrapolated from the two lowest "
                             "blade-angle lines)")
    parser.add_argument("--no-extension", action="store_true",
                        help="with --simulator-nets: train on the table alone (with --closed-opening: plus Q11 = 0 "
                             "at the closed vane). By default the nets learn the residual to the physical bulb model "
                             "fitted to the table, which answers where the table is silent: runaway, the closed vane "
                             "(M11 = -K N11^2), zero speed and the overspeed between them")
    parser.add_argument("--members", type=int, default=5,
                        help=f"with --simulator-nets: ensemble members, the point nets included, 1-{MAX_MEMBERS} "
                             "(default 5)")
    parser.add_argument("--out", required=True, help="output folder (fccm_nets.json, metrics.json, PNGs)")
    parser.add_argument("--hidden", type=int, default=None,
                        help="hidden neurons (default: eq. (3) of Wu et al. with C in 1..10 chosen by validation; "
                             "with --simulator-nets 30 (15 with --no-extension), or 8 for an on-cam chart)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the split and the initialisations (default 0)")
    parser.add_argument("--restarts", type=int, default=5, help="initialisations per hidden size (default 5)")
    parser.add_argument("--split", default="0.30,0.35,0.35",
                        help="train,validation,test fractions (default 0.30,0.35,0.35 as Wu et al.)")
    parser.add_argument("--truth", default=None, help="exact grid CSV (e.g. truth.csv of hillsim synth --turbine "
                        "bulb): net and linear interpolation against it")
    parser.add_argument("--no-plots", action="store_true", help="skip the PNG figures")
    parser.set_defaults(func=run)


def _names(option: str, text: str) -> list[str]:
    from hillchart.errors import InputError

    names = [n.strip() for n in text.split(",")]
    if not text.strip() or any(not n for n in names):
        raise InputError(f"{option} must be comma-separated column names, got {text!r}")
    return names


def _split(text: str) -> tuple:
    from hillchart.errors import InputError

    try:
        parts = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"--split must be three comma-separated fractions, got {text!r}") from None
    if len(parts) != 3:
        raise InputError(f"--split must be three comma-separated fractions (train,validation,test), got {text!r}")
    return parts


def run(args: argparse.Namespace) -> int:
    from hillchart.errors import InputError
    from hillchart.fccm.analysis import analyse_fccm
    from hillchart.fccm.maps import format_grey_relational_table, read_truth_csv
    from hillchart.fccm.net import FCCMNet
    from hillchart.fccm.table import load_test_table

    if args.simulator_nets:
        return _run_simulator_nets(args)
    for option, value in (("--inputs", args.inputs), ("--outputs", args.output_columns)):
        if value is None:
            raise InputError(f"{option} is required (or --simulator-nets for the simulator's three-input nets)")
    inputs, outputs = _names("--inputs", args.inputs), _names("--outputs", args.output_columns)
    if args.hidden is not None and not 1 <= args.hidden <= 100:
        raise InputError(f"--hidden must be an integer within 1-100, got {args.hidden}")
    for option, value, low in (("--seed", args.seed, 0), ("--restarts", args.restarts, 1)):
        if value < low:
            raise InputError(f"{option} must be an integer >= {low}, got {value}")
    net = FCCMNet(hidden=args.hidden, seed=args.seed, restarts=args.restarts, split=_split(args.split))
    net._validate_params()  # bad --split before any file is read
    out = args.outputs.folder("--out", args.out)  # checked (and locked) before the work; in place at the end
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        table = load_test_table(args.table)
    for w in caught:  # unit look-alikes (flow in l/s, power in W, angles in radians): said before the training
        print(f"warning: {w.message}", flush=True)
    truth = read_truth_csv(args.truth) if args.truth else None
    report = analyse_fccm(table, inputs, outputs, net=net, truth=truth)
    written = report.write(out, plots=not args.no_plots)
    m = report.metrics
    rule = f"C = {m['c']} of eq. (3)" if m["c"] is not None else "fixed"
    print(f"table {table.info.name!r}: {table.n_rows} points; net {len(inputs)}-{m['hidden']}-{len(outputs)} "
          f"({rule}), split {net.split}, seed {args.seed}")
    print(f"{'output':<16} {'train RMSE':>12} {'val RMSE':>12} {'test RMSE':>12} {'test max':>12}")
    for o in outputs:
        e = m["errors"][o]
        print(f"{o:<16} {e['train']['rmse']:>12.5g} {e['validation']['rmse']:>12.5g} {e['test']['rmse']:>12.5g} "
              f"{e['test']['max_abs_error']:>12.5g}")
    if "similarity" in m:
        s = m["similarity"]
        print(f"image similarity (interpolation vs net): Euclidean {s['euclidean']:.4f}, cosine {s['cosine']:.5f}, "
              f"angle {s['angle_deg']:.2f} deg, pixel RMS {s['pixel_rms']:.2f} grey levels ({s['pixels']} pixels)")
    if "grey_relational" in m:
        print(format_grey_relational_table(m["grey_relational"]))
    if "truth" in m:
        t = m["truth"]
        print(f"against the truth ({t['points']} grid points):")
        for o in outputs:
            print(f"  {o:<16} net RMS {t[o]['net_rms_pct']:.3f} %, linear interpolation "
                  f"{t[o]['interpolation_rms_pct']:.3f} % of the range")
        print(f"  acceptance (RMS <= 1.5 %, net better for >= 3 outputs): "
              f"{'PASS' if m['acceptance']['passed'] else 'FAIL'}")
    for name, reason in m["skipped"].items():
        print(f"skipped {name}: {reason}")
    for w in m["warnings"]:
        print(f"warning: {w}")
    for path in written.values():
        print(f"wrote {Path(args.out) / Path(path).relative_to(out)}")
    return 0


def _run_simulator_nets(args) -> int:
    """``--simulator-nets``: three-input nets for the simulator from the table (nets.json, plausibility.json)."""
    import json
    import warnings

    from hillchart.errors import InputError
    from hillchart.fccm.double_regulated import table_unit_samples, train_table_nets
    from hillchart.fccm.on_cam import is_on_cam_table
    from hillchart.fccm.table import load_test_table

    if args.inputs is not None or args.output_columns is not None:
        raise InputError("--simulator-nets trains Q11 and M11 on (n11, guide_vane_deg, blade_angle_deg): drop "
                         "--inputs and --outputs")
    if args.hidden is not None and not 1 <= args.hidden <= 100:
        raise InputError(f"--hidden must be an integer within 1-100, got {args.hidden}")
    for option, value, low in (("--seed", args.seed, 0), ("--restarts", args.restarts, 1)):
        if value < low:
            raise InputError(f"{option} must be an integer >= {low}, got {value}")
    if not 1 <= args.members <= MAX_MEMBERS:
        raise InputError(f"--members must be an integer within 1-{MAX_MEMBERS}, got {args.members} (each member "
                         f"trains both nets; the default 5 gives the ensemble spread)")
    split = _split(args.split) if args.split != "0.30,0.35,0.35" else (0.70, 0.15, 0.15)
    out = args.outputs.folder("--out", args.out)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        table = load_test_table(args.table)
    for w in caught:
        print(f"warning: {w.message}", flush=True)
    if table.n_rows > MAX_SIMULATOR_NET_ROWS:
        raise InputError(f"{Path(args.table) / 'table.csv'}: {table.n_rows} rows; --simulator-nets trains on at "
                         f"most {MAX_SIMULATOR_NET_ROWS} (a model test has some hundreds to a few thousand points): "
                         "thin the table (e.g. every n-th row, or the points of one test campaign)")
    if is_on_cam_table(table):
        return _run_on_cam_nets(args, table, split, out)
    hidden = (15 if args.no_extension else 30) if args.hidden is None else args.hidden
    samples, notes, model = table_unit_samples(table, opening_closed=args.closed_opening, seed=args.seed,
                                               extension=not args.no_extension)
    nets, report = train_table_nets(samples, hidden=hidden, restarts=args.restarts, seed=args.seed,
                                    members=args.members, split=split, model=model)
    nets.training["notes"] = notes
    if model is not None:
        nets.training["boundary_model"] = model.to_dict()
    nets.save(out / "nets.json")
    (out / "plausibility.json").write_text(json.dumps({**report, "notes": notes}, indent=2) + "\n", encoding="utf-8")
    p = report["plausibility"]
    print(f"table {table.info.name!r}: {samples['n11'].size} unit samples; nets 3-{hidden}-1 (Q11, M11), "
          f"{p['ensemble_members']} ensemble members")
    print(f"plausibility: dQ11/da < 0 on {100 * p['share_dq11_da_negative']:.1f} % of the box, efficiency up to "
          f"{p['max_efficiency']:.3f}, ensemble spread Q11 {p['ensemble_spread_q11_pct']:.2f} %, "
          f"M11 {p['ensemble_spread_m11_pct']:.2f} % of their ranges")
    at_limit = model is not None and model.closed_at_limit
    for line in notes:  # nets.json keeps each note whole; the closed vane at the limit is printed once, as a warning
        print(f"note: {line.split(f'; {model.closed_limit_text}')[0] if at_limit else line}")
    for line in report["warnings"]:
        print(f"warning: {line}")
    if at_limit:  # the plant's stroke and everything below the table rest on it
        print(f"warning: {model.closed_limit_text}; the plant's stroke (turbine.opening_max) and the answer below "
              "the smallest tested angle rest on it: give --closed-opening (the angle at which the vanes touch, from "
              "the guide-vane drawing) if it is known")
    if "extrapolation" in nets.training:  # the table's own held-out angles: how far below it to trust the answer
        print(nets.training["extrapolation"]["summary"])
    if model is not None:
        box = nets.training["measured_box"]
        blades = ('combinator.relation = "off", fixed_angle_deg = ' + f"{box['blade_angle'][0]:g}"
                  if box["blade_angle"][0] == box["blade_angle"][1] else
                  'combinator.relation = "model" (the cam of the fitted model; "table" with the unit\'s measured '
                  'cam is better)')
        where = " at the model's limit, see the warning" if model.closed_at_limit else ""
        print(f"plant: combinator.opening_at_zero_stroke = {model.opening_closed:.4g} (the closed vane, deg{where}), "
              f"turbine.opening_max = {box['opening'][1] - model.opening_closed:.4g} (to the largest tested angle), "
              f"{blades}")
    print(f"wrote {Path(args.out) / 'nets.json'}, {Path(args.out) / 'plausibility.json'}")
    return 0


def _run_on_cam_nets(args, table, split, out) -> int:
    """An on-cam table (blade angle, no guide-vane angle): two-input nets over (n11, cam position) that the
    simulator runs as a single-regulated unit, with the warning of what they cannot represent."""
    import json

    from hillchart.fccm.on_cam import ON_CAM_WARNING, on_cam_unit_samples, train_on_cam_nets

    hidden = 8 if args.hidden is None else args.hidden
    samples, notes, closed = on_cam_unit_samples(table, closed_angle_deg=args.closed_opening, seed=args.seed)
    nets, report = train_on_cam_nets(samples, hidden=hidden, restarts=args.restarts, seed=args.seed,
                                     members=args.members, split=split)
    nets.training["notes"] = notes
    nets.training["closed_cam_blade_angle_deg"] = closed
    nets.save(out / "nets.json")
    (out / "plausibility.json").write_text(json.dumps({**report, "notes": notes}, indent=2) + "\n", encoding="utf-8")
    p = report["plausibility"]
    span = float(nets.flow.x_max[1])
    print(f"table {table.info.name!r}: an on-cam chart; {samples['n11'].size} unit samples; two-input nets "
          f"2-{hidden}-1 (Q11, M11) over (n11, cam position), {p['ensemble_members']} ensemble members")
    print(f"plausibility: dQ11/dc < 0 on {100 * p['share_dq11_dc_negative']:.1f} % of the box, efficiency up to "
          f"{p['max_efficiency']:.3f}, ensemble spread Q11 {p['ensemble_spread_q11_pct']:.2f} %, "
          f"M11 {p['ensemble_spread_m11_pct']:.2f} % of their ranges")
    for line in notes:
        if line != ON_CAM_WARNING:  # said once, as a warning
            print(f"note: {line}")
    for line in report["warnings"]:
        print(f"warning: {line}")
    print(f"plant: turbine.characteristics = this nets.json, turbine.opening_max = {span:.4g} (the cam from closed "
          f"to the largest blade angle, deg), no [combinator] or [blade_servo]")
    print(f"wrote {Path(args.out) / 'nets.json'}, {Path(args.out) / 'plausibility.json'}")
    return 0
