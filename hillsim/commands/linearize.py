"""``hillsim linearize NETS --n11 X --opening A [--blade-angle PHI] [--map out.png]``: the six transfer coefficients
from the nets (eight for a double-regulated turbine: the blade angle's ``ephi``, ``eqphi`` per degree).

Prints one JSON object: the operating point, ``ex, ey, eh, eqx, eqy, eqh`` (analytic derivatives of the nets, see
:mod:`hillchart.linearize`) and paper 002's ``e``. ``NETS`` is a ``nets.json``, the word ``synthetic`` (the exact
synthetic Francis turbine the shipped chart was drawn from, for comparison) or, with ``--plant``, ``ideal``.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from hillchart.errors import InputError
from hillsim import progress
from hillsim.commands import add_set_option, load_command_plant
from hillchart.characteristics import unit_speed



def _penstock_models() -> tuple[str, ...]:
    """The penstock models of the registry (the built-in ones and any registered before the parser is built)."""
    from simulate.components.registry import PENSTOCKS

    return PENSTOCKS.names()

def load_characteristics(source: str, plant=None):
    """``(characteristics, label, opening_unit)`` for ``NETS``, through the one resolver of every command
    (:func:`simulate.components.turbine.kinds.load_kind`): a nets.json path, or a registry word (``"synthetic"``,
    ``"synthetic-bulb"``, ``"ideal"``, which needs ``--plant``: the ideal turbine from the plant's rated values)
    labelled by its kind."""
    from simulate.components.turbine.kinds import kind_of, load_kind

    name, characteristics, path, _ = load_kind(source, turbine=plant.turbine if plant is not None else None,
                                               key="NETS")
    if path is None:
        return characteristics, kind_of(name).label, kind_of(name).opening_unit
    return characteristics, str(source), getattr(characteristics, "opening_unit", "chart units")


def _check_inputs_match(nets: str, characteristics, plant) -> None:
    """NETS in place of the plant's characteristics: two-input ones for a single-regulated unit, three-input ones
    for a double-regulated one (a ``[combinator]`` or ``[blade_servo]``); the message names NETS, not the plant's
    own ``turbine.characteristics``."""
    from simulate.components.turbine.double_regulated import is_three_input

    double = getattr(plant, "combinator", None) is not None or getattr(plant, "blade_servo", None) is not None
    three = is_three_input(characteristics)
    if double and not three:
        raise InputError(f"NETS {nets!r} has two inputs, but the plant is double-regulated ([combinator], "
                         f"[blade_servo]): give three-input nets (n11, opening, blade_angle), e.g. the plant's own "
                         f"turbine.characteristics = {plant.turbine.characteristics!r}")
    if three and not double:
        raise InputError(f"NETS {nets!r} has three inputs (a blade angle), but the plant has no [combinator]: give "
                         f"two-input nets, e.g. the plant's own turbine.characteristics = "
                         f"{plant.turbine.characteristics!r}, or a double-regulated plant file")


def _chart_ranges(characteristics):
    """(n11_lo, n11_hi), (a_lo, a_hi) of the nets' input normalization, when the object has one."""
    flow = getattr(characteristics, "flow", None)
    if flow is not None and hasattr(flow, "x_min") and hasattr(flow, "x_max"):
        lo, hi = np.asarray(flow.x_min, float), np.asarray(flow.x_max, float)
        return (lo[0], hi[0]), (lo[1], hi[1])
    opening_max = getattr(characteristics, "opening_max", None)
    if opening_max is not None:
        return (30.0, 110.0), (0.0, float(opening_max))
    return None, None


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "linearize",
        help="six transfer coefficients (ex, ey, eh, eqx, eqy, eqh) from the nets at an operating point",
        description="Six coefficients of the linear turbine model from the nets' analytic derivatives "
                    "(Wang et al. 2023, eqs. 4-7). Prints JSON; --map draws each coefficient over (N11, a).",
    )
    parser.add_argument("nets", metavar="NETS",
                        help="nets.json (two-input, or three-input with a blade angle), 'synthetic' for the exact "
                             "synthetic turbine, 'synthetic-bulb' for the exact double-regulated bulb, or with "
                             "--plant 'ideal' (the ideal turbine from the plant's rated values)")
    point = parser.add_argument_group("operating point (either N11 directly or speed, head and diameter)")
    point.add_argument("--n11", type=float, default=None, help="unit speed N11, r/min")
    point.add_argument("--opening", type=float, default=None, help="guide-vane opening, chart units (> 0)")
    point.add_argument("--blade-angle", type=float, default=None,
                       help="runner-blade angle, deg: with three-input (double-regulated) characteristics, which "
                            "give eight coefficients (the six and the blade angle's ephi, eqphi, per degree)")
    point.add_argument("--plant", default=None, metavar="TOML",
                       help="linearize at this plant's initial operating point (its scenario's initial power or "
                            "opening, or --stroke) with NETS as the characteristics; adds the linear plant model")
    point.add_argument("--stroke", type=float, default=None, help="with --plant: operating stroke fraction")
    point.add_argument("--penstock-model", choices=_penstock_models(), default=None,
                       help="with --plant: rigid gives the inelastic model, otherwise the lumped elastic one")
    point.add_argument("--tau", type=float, default=0.2, help="with --plant: sampling time of the ARX, s")
    add_set_option(point, help="with --plant: override a plant-file key, as in hillsim run; the value is parsed "
                               "as TOML (repeatable), e.g. --set penstock.static_head_m=170")
    point.add_argument("--speed-rpm", type=float, default=None, help="shaft speed n, r/min (with --head-m, --d1-m)")
    point.add_argument("--head-m", type=float, default=None, help="net head H, m")
    point.add_argument("--d1-m", type=float, default=None, help="runner diameter D1, m")
    maps = parser.add_argument_group("coefficient maps")
    maps.add_argument("--map", default=None, metavar="PNG", help="draw each coefficient over (N11, a) into PNG")
    maps.add_argument("--n11-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                      help="N11 range of the map, r/min (default: the nets' input range, from 1 r/min)")
    maps.add_argument("--opening-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                      help="opening range of the map (default: the nets' input range, from 5 %% of its top)")
    maps.add_argument("--grid", type=int, default=60, help="grid points per axis of the map (default 60)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from hillchart.linearize import coefficient_maps, plot_coefficient_maps, six_coefficients, six_coefficients_at

    from hillsim.outputs import check_picture_suffix

    check_picture_suffix("--map", args.map)
    map_png = args.outputs.file("--map", args.map)  # checked now, renamed into place at the end
    if args.plant is not None:
        return _run_plant(args)
    characteristics, label, opening_unit = load_characteristics(args.nets)
    if args.stroke is not None or args.penstock_model is not None:
        raise InputError("--stroke and --penstock-model need --plant")
    if args.overrides:
        raise InputError(f"--set {args.overrides[0]!r} needs --plant: it overrides a key of the plant file")
    from simulate.components.turbine.double_regulated import is_three_input

    if is_three_input(characteristics):
        return _run_eight(args, characteristics, label, opening_unit)
    if args.blade_angle is not None:
        raise InputError(f"--blade-angle needs three-input characteristics (a double-regulated turbine); {args.nets!r} "
                         f"has two inputs")
    if args.opening is None:
        raise InputError("the operating point needs --opening (chart units), or --plant")
    physical = (args.speed_rpm, args.head_m, args.d1_m)
    if args.n11 is not None and any(v is not None for v in physical):
        raise InputError("give either --n11 or --speed-rpm/--head-m/--d1-m, not both")
    if args.n11 is not None:
        coeffs = six_coefficients(characteristics, n11=args.n11, opening=args.opening)
        point = {"n11_rpm": args.n11, "opening": args.opening}
    elif all(v is not None for v in physical):
        coeffs = six_coefficients_at(characteristics, speed_rpm=args.speed_rpm, head_m=args.head_m,
                                     runner_diameter_m=args.d1_m, opening=args.opening)
        point = {"speed_rpm": args.speed_rpm, "head_m": args.head_m, "runner_diameter_m": args.d1_m,
                 "n11_rpm": coeffs.n11_rpm, "opening": args.opening}
    else:
        raise InputError("the operating point needs --n11, or all of --speed-rpm, --head-m and --d1-m")
    record = coeffs.to_dict()
    import sys

    from simulate.components.turbine.kinds import nets_path
    from simulate.loop.domain import point_warnings  # never extrapolate silently

    path = nets_path(args.nets)
    domain_dir = None if path is None else path.parent
    warnings = point_warnings(characteristics, record["n11_rpm"], args.opening, chart_dir=domain_dir)
    for line in warnings:
        print(f"hillsim linearize: warning: {line}", file=sys.stderr)
    out = {
        "source": label,
        "opening_unit": opening_unit,
        "operating_point": point | {"q11_m3_s": record["q11_m3_s"], "m11_nm": record["m11_nm"]},
        "coefficients": {k: record[k] for k in ("ex", "ey", "eh", "eqx", "eqy", "eqh")},
        "e": coeffs.e,  # paper 002: e = eqy eh / ey - eqh
        "warnings": warnings,
    }
    if getattr(characteristics, "ensemble", None):  # uncertainty band of the ensemble
        from hillchart.linearize import six_coefficients_band

        band = six_coefficients_band(characteristics, n11=coeffs.n11_rpm, opening=args.opening)
        out["band_5_95"] = {k: [v["low"], v["high"]] for k, v in band.items()}
        out["ensemble_mean"] = {k: v["mean"] for k, v in band.items()}
        out["ensemble_members"] = len(characteristics.ensemble)
    if args.map is not None:
        if args.grid < 2 or args.grid > 1000:
            raise InputError(f"--grid must be in [2, 1000], got {args.grid}")
        n_rng, a_rng = _chart_ranges(characteristics)
        n_lo, n_hi = args.n11_range if args.n11_range else (max(1.0, n_rng[0]), n_rng[1]) if n_rng else (None, None)
        a_lo, a_hi = (args.opening_range if args.opening_range
                      else (max(a_rng[0], 0.05 * a_rng[1]), a_rng[1]) if a_rng else (None, None))
        if n_lo is None or a_lo is None:
            raise InputError("--map needs --n11-range and --opening-range for these characteristics")
        for name, lo, hi in (("--n11-range", n_lo, n_hi), ("--opening-range", a_lo, a_hi)):
            if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo < hi):
                raise InputError(f"{name} must satisfy 0 < LO < HI, got {lo} {hi}")
        progress.start(f"coefficient maps on a {args.grid} x {args.grid} grid")
        maps = coefficient_maps(characteristics, np.linspace(n_lo, n_hi, args.grid), np.linspace(a_lo, a_hi, args.grid))
        plot_coefficient_maps(maps, map_png, operating_point=(coeffs.n11_rpm, coeffs.opening),
                              opening_unit=opening_unit)
        out["map"] = str(args.map)
        progress.done()
    print(json.dumps(out, indent=2))
    return 0


def _run_plant(args) -> int:
    from simulate.identification.results import to_json_dict
    from simulate.identification.linear_reference import plant_linearization

    if any(v is not None for v in (args.n11, args.opening, args.speed_rpm, args.head_m, args.d1_m)):
        raise InputError("with --plant the operating point comes from the plant (use --stroke to choose it); "
                         "drop --n11/--opening/--speed-rpm/--head-m/--d1-m")
    if args.map is not None:
        raise InputError("--map draws the chart maps: use it without --plant")
    if not (np.isfinite(args.tau) and args.tau > 0):
        raise InputError(f"--tau must be > 0, got {args.tau}")
    plant = load_command_plant("linearize", args.plant, args.overrides)
    plant.require_one_unit("hillsim linearize --plant")
    characteristics, label, opening_unit = load_characteristics(args.nets, plant)
    _check_inputs_match(args.nets, characteristics, plant)
    out = {"source": label, "opening_unit": opening_unit, "plant": str(args.plant)}
    out |= to_json_dict(plant_linearization(plant, characteristics, initial_opening=args.stroke,
                                            penstock_model=args.penstock_model, sample_time_s=args.tau))
    print(json.dumps(out, indent=2))
    return 0


def _run_eight(args, characteristics, label, opening_unit) -> int:
    """Eight coefficients of three-input characteristics at (N11, opening, blade angle)."""
    import sys

    from hillchart.linearize import EIGHT_COEFFICIENT_NAMES, eight_coefficients

    if args.map is not None:
        raise InputError("--map draws two-input charts: it does not take three-input characteristics")
    if args.opening is None or args.blade_angle is None:
        raise InputError("three-input characteristics need --opening (chart units) and --blade-angle (deg)")
    n11 = args.n11
    if n11 is None:
        if any(v is None for v in (args.speed_rpm, args.head_m, args.d1_m)):
            raise InputError("the operating point needs --n11, or all of --speed-rpm, --head-m and --d1-m")
        for name, value in (("--speed-rpm", args.speed_rpm), ("--head-m", args.head_m), ("--d1-m", args.d1_m)):
            if not (np.isfinite(value) and value > 0):
                raise InputError(f"{name} must be > 0, got {value}")
        n11 = float(unit_speed(args.speed_rpm, args.head_m, args.d1_m))
    coeffs = eight_coefficients(characteristics, n11=n11, opening=args.opening, blade_angle=args.blade_angle)
    record = coeffs.to_dict()
    warnings = []
    flow = getattr(characteristics, "flow", None)
    if flow is not None and hasattr(flow, "x_min"):
        point = (record["n11_rpm"], args.opening, args.blade_angle)
        outside = [f"{name} {value:.4g} outside {lo:.4g}-{hi:.4g}" for name, value, lo, hi in
                   zip(("N11", "opening", "blade angle"), point, flow.x_min, flow.x_max) if not lo <= value <= hi]
        if outside:
            warnings.append("the point is outside the nets' training range (" + ", ".join(outside) + "): the "
                            "coefficients are extrapolated; choose a point inside it")
    for line in warnings:
        print(f"hillsim linearize: warning: {line}", file=sys.stderr)
    out = {"source": label, "opening_unit": opening_unit,
           "operating_point": {"n11_rpm": record["n11_rpm"], "opening": args.opening,
                               "blade_angle_deg": args.blade_angle, "q11_m3_s": record["q11_m3_s"],
                               "m11_nm": record["m11_nm"]},
           "coefficients": {k: record[k] for k in EIGHT_COEFFICIENT_NAMES},
           "coefficient_units": {"ephi": "1/deg", "eqphi": "1/deg"},
           "warnings": warnings}
    print(json.dumps(out, indent=2))
    return 0
