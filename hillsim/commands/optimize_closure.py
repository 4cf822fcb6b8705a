"""``hillsim optimize-closure plant.toml --max-speed-rise 0.50 --out DIR`` (or ``--max-head-rise``): the two-stage
guide-vane closure law that minimizes the worst max head rise (speed rise) over the plant's load cases under the
other limit, its Pareto front against the linear-closure family, and a verification of the optimum by ``hillsim run``.

Writes ``DIR/closure.json``, ``DIR/pareto.png``, ``DIR/law.png``, ``DIR/optimum_plant.toml`` (a study file: the law,
the worst load case, the limits and load cases; see :func:`optimum_plant_toml`) and ``DIR/verification/<n>/`` (the
``hillsim run`` output of each load case).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

from hillchart.errors import InputError, NumericalError

#: Largest accepted |batch - hillsim run| of the verified figures (the same code path: they should be identical).
VERIFY_TOLERANCE = 1e-9


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "optimize-closure", help="optimize a two-stage guide-vane closure law over the plant's load cases",
        description="Find the two-stage closure law (first-stage rate, break point, second-stage rate) that minimizes "
                    "the worst max head rise under --max-speed-rise (or the worst max speed rise under "
                    "--max-head-rise) over the plant file's [[load_cases]], compare with the best linear closure, "
                    "and verify the optimum with hillsim run.")
    parser.add_argument("plant", type=Path, help="plant TOML file (optional [limits] and [[load_cases]])")
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--max-speed-rise", type=float, default=None, metavar="FRACTION",
                       help="limit on max|n|/|n0| - 1; minimize the max head rise (default: limits.max_speed_rise)")
    group.add_argument("--max-head-rise", type=float, default=None, metavar="FRACTION",
                       help="limit on max(H)/H0 - 1; minimize the max speed rise")
    parser.add_argument("--out", type=Path, required=True, help="output directory (created if missing)")
    parser.add_argument("--ensemble", action="store_true",
                        help="apply the limit to the worst case over the nets and the \"ensemble\" members of the "
                             "plant's nets.json")
    parser.add_argument("--seed", type=int, default=0, help="differential-evolution seed (default 0)")
    parser.add_argument("--maxiter", type=int, default=25, help="generations (default 25)")
    parser.add_argument("--popsize", type=int, default=10, help="population = popsize x 3 laws (default 10)")
    parser.add_argument("--workers", type=int, default=None, help="parallel workers (default: available cores)")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="SECTION.KEY=VALUE",
                        help="override a plant-file key (as in hillsim run)")
    parser.add_argument("--no-plot", action="store_true", help="do not write pareto.png and law.png")
    parser.set_defaults(func=optimize_command)


def _law_row(ev) -> dict:
    return {**ev.law.as_dict(), "max_speed_rise": ev.max_speed_rise, "max_head_rise": ev.max_head_rise,
            "feasible": ev.feasible_runs, "problem": ev.problem}


def plot_outputs(opt, plant, load_cases, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from simulate.components.control.governor import closure_law

    fig, ax = plt.subplots(figsize=(7, 5))
    lin = [g for g in opt.linear_family if g.feasible_runs]
    ax.plot([g.max_speed_rise for g in lin], [g.max_head_rise for g in lin], "o-", ms=3, color="tab:gray",
            label="linear closure family (T1 grid)")
    front = opt.pareto_two_stage
    ax.plot([f.max_speed_rise for f in front], [f.max_head_rise for f in front], "-", color="tab:blue",
            label=f"two-stage Pareto front ({len(front)} of {opt.evaluations} laws evaluated)")
    ax.plot(opt.law.max_speed_rise, opt.law.max_head_rise, "*", ms=14, color="tab:red",
            label=f"two-stage optimum ({opt.law.max_speed_rise:.3f}, {opt.law.max_head_rise:.3f})")
    ax.plot(opt.best_linear.max_speed_rise, opt.best_linear.max_head_rise, "s", ms=9, color="k",
            label=f"best linear ({opt.best_linear.max_speed_rise:.3f}, {opt.best_linear.max_head_rise:.3f})")
    if opt.mode == "head":
        ax.axvline(opt.limit, color="tab:red", ls="--", lw=1, label=f"limit max speed rise {opt.limit:g}")
    else:
        ax.axhline(opt.limit, color="tab:red", ls="--", lw=1, label=f"limit max head rise {opt.limit:g}")
    xs = [g.max_speed_rise for g in lin] + [opt.law.max_speed_rise]
    ax.set_xlim(min(xs) - 0.02, max(xs) + 0.02)
    ys = [g.max_head_rise for g in lin] + [opt.law.max_head_rise]
    ax.set_ylim(max(0.0, min(ys) - 0.05), min(max(ys), 4 * max(opt.best_linear.max_head_rise,
                                                             opt.law.max_head_rise)) + 0.05)
    ax.set_xlabel("worst max speed rise (fraction)")
    ax.set_ylabel("worst max head rise (fraction)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"closure laws over {len(load_cases)} load case(s)")
    fig.tight_layout()
    fig.savefig(out / "pareto.png", dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 4))
    y0 = opt.law.cases[0].initial_opening
    event = plant.scenario.event_time_s
    for ev, style, name in ((opt.law, "-", "two-stage optimum"), (opt.best_linear, "--", "best linear")):
        law = ev.law
        t, y = closure_law(y0, event, law.closing_time_s, law.break_opening, law.break_time_s)
        t = np.concatenate(([0.0], t, [plant.scenario.t_end_s]))
        y = np.concatenate(([y0], y, [0.0]))
        ax.plot(t, y, style, label=f"{name} ({load_cases[0].name})")
    ax.axvline(event, color="gray", lw=0.8)
    ax.annotate("load rejection", (event, y0), xytext=(4, 4), textcoords="offset points", fontsize=8)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("guide-vane stroke")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "law.png", dpi=110)
    plt.close(fig)


def verify(opt, plant, load_cases, out: Path) -> list[dict]:
    """Run the optimum of each load case through ``hillsim run`` (a written plant file) and compare its
    summary.json with the batch record (nets of the plant, member 0)."""
    from hillsim.cli import main
    from simulate.studies.batch import variant_overrides
    from simulate.studies.cases import plant_toml

    rows = []
    for i, lc in enumerate(load_cases):
        folder = out / "verification" / str(i)
        folder.mkdir(parents=True, exist_ok=True)
        case_plant = plant.with_overrides(variant_overrides({**lc.overrides, **opt.law.law.overrides()}))
        plant_file = folder / "plant.toml"
        plant_file.write_text(plant_toml(case_plant, relative_to=folder), encoding="utf-8")
        code = main(["run", str(plant_file), "--out", str(folder), "--no-plot"])
        if code != 0:
            raise NumericalError(f"verification run of load case {lc.name!r} failed (exit {code}); see {folder}")
        summary = json.loads((folder / "summary.json").read_text(encoding="utf-8"))
        case = opt.law.cases[i]
        diffs = {k: abs(summary[k] - getattr(case, k)) for k in ("max_speed_rise", "max_head_rise", "max_head_m")}
        rows.append({"load_case": lc.name, "plant_file": str(plant_file.relative_to(out)),
                     **{f"{k}_batch": getattr(case, k) for k in diffs},
                     **{f"{k}_hillsim_run": summary[k] for k in diffs},
                     "max_abs_difference": max(diffs.values())})
    return rows


def optimum_plant_toml(source: Path, study, plant, law, worst: int, folder: Path) -> str:
    """``optimum_plant.toml``: a complete study file. The plant with the optimum ``law`` and the keys of the worst
    load case (what ``hillsim run`` runs), the study's ``[limits]`` and its ``[[load_cases]]`` each with every key
    another case sets (:func:`simulate.studies.cases.explicit_load_cases`: what ``hillsim report`` runs is each
    case of the study under the law); the characteristics path relative to ``folder``, where the file is written."""
    from simulate.studies.batch import variant_overrides
    from simulate.studies.cases import LoadCase, explicit_load_cases, plant_toml, study_toml

    with_law = plant.with_overrides(variant_overrides(law.overrides()))
    # the law wins over a case's own key of it, as in the optimization; a case left with no key keeps the end time
    cases = tuple(LoadCase(lc.name, {k: v for k, v in lc.overrides.items() if k not in law.overrides()}
                           or ({"scenario.t_end_s": plant.scenario.t_end_s} if lc.overrides else {}))
                  for lc in explicit_load_cases(study.load_cases, with_law))
    base = with_law.with_overrides(variant_overrides(cases[worst].overrides)) if cases[worst].overrides else with_law
    header = (f"# The plant of {Path(source).name} with the optimum two-stage closure law of hillsim optimize-closure "
              f"and the keys of its\n# worst load case ({study.load_cases[worst].name}), which hillsim run runs; "
              f"[limits] and [[load_cases]] of the study follow,\n# each load case with every key another one "
              f"sets, for hillsim report.\n\n")
    return header + plant_toml(base, relative_to=folder) + "\n" + study_toml(study.limits, cases)


def optimize_command(args: argparse.Namespace) -> int:
    from simulate.studies.closure_opt import closure_plant, optimize_closure
    from simulate.components.turbine.component import plant_turbine
    from simulate.config import parse_override
    from simulate.studies.cases import load_study

    for name in ("maxiter", "popsize", "workers"):
        value = getattr(args, name)
        if value is not None and value < 1:
            raise InputError(f"--{name} must be an integer >= 1, got {value}")
    for name in ("max_speed_rise", "max_head_rise"):
        value = getattr(args, name)
        if value is not None and not (math.isfinite(value) and 0.0 < value <= 5.0):
            raise InputError(f"--{name.replace('_', '-')} must be a fraction in (0, 5], got {value!r}")
    from hillsim.commands.sweep import cap_workers

    if not 0 <= args.seed <= 2**32 - 1:  # numpy's generators take no negative seed
        raise InputError(f"--seed must be an integer in [0, 4294967295], got {args.seed}")
    args.workers = cap_workers(args.workers)
    out = args.outputs.folder("--out", args.out)  # checked and locked now, moved into place when complete
    study = load_study(args.plant, dict(parse_override(t) for t in args.overrides))
    if args.max_speed_rise is not None:
        mode, limit = "head", args.max_speed_rise
    elif args.max_head_rise is not None:
        mode, limit = "speed", args.max_head_rise
    elif study.limits is not None and study.limits.max_speed_rise is not None:
        mode, limit = "head", study.limits.max_speed_rise
    elif study.limits is not None and study.limits.max_head_rise is not None:
        mode, limit = "speed", study.limits.max_head_rise
    else:
        raise InputError("give --max-speed-rise or --max-head-rise (or limits.max_speed_rise in the plant file)")
    plant = closure_plant(study.plant)
    turbine = plant_turbine(plant)
    base = turbine.characteristics
    members = [base]
    if args.ensemble:
        if turbine.path is None:
            raise InputError("--ensemble needs turbine.characteristics to be a nets.json with an \"ensemble\" list")
        extra = base.members() if hasattr(base, "members") else []  # stepped up with the point nets, if asked
        if not extra:
            raise InputError(f"--ensemble: {plant.turbine.characteristics!r} has no \"ensemble\" list")
        members += extra
    from simulate.studies.batch import variant_overrides
    from simulate.loop.engine import initial_state

    for lc in study.load_cases:  # a load case the unit cannot start from is named now, not as "no law runs"
        try:
            initial_state(plant.with_overrides(variant_overrides(lc.overrides)) if lc.overrides else plant, base)
        except InputError as exc:
            keys = ", ".join(sorted(lc.overrides)) or "no key"
            raise InputError(f"load case {lc.name!r} (setting {keys}): {exc}") from None
    print(f"optimize-closure: {len(study.load_cases)} load case(s) x {len(members)} characteristics; minimize "
          f"max {mode} rise with max {'speed' if mode == 'head' else 'head'} rise <= {limit:g}", flush=True)

    def progress(generation, evaluations):
        if generation % 5 == 0:
            print(f"optimize-closure: generation {generation}, {evaluations} laws evaluated", flush=True)

    opt = optimize_closure(plant, study.load_cases, mode=mode, limit=limit, members=members, seed=args.seed,
                           maxiter=args.maxiter, popsize=args.popsize, workers=args.workers, progress=progress)
    out.mkdir(parents=True, exist_ok=True)
    verification = verify(opt, plant, study.load_cases, out)
    worst_diff = max(v["max_abs_difference"] for v in verification)
    law = opt.law
    cases = [{"load_case": study.load_cases[k % len(study.load_cases)].name,
              "member": k // len(study.load_cases), "status": c.status,
              "max_speed_rise": c.max_speed_rise, "max_head_rise": c.max_head_rise, "max_head_m": c.max_head_m,
              "initial_opening": c.initial_opening,
              "closure_end_s": plant.scenario.event_time_s + law.law.duration_s(c.initial_opening),
              "max_unit_speed_rpm": c.max_unit_speed_rpm, "beyond_nets_range": c.beyond_nets_range,
              "extrapolated": c.extrapolated}
             for k, c in enumerate(law.cases)]
    extrapolated = [f"{c['load_case']} (member {c['member']})" for c in cases if c["extrapolated"]]
    doc = {
        "plant_file": str(args.plant), "plant_sha256": study.sha256, "mode": mode,
        "objective": "max_head_rise" if mode == "head" else "max_speed_rise",
        "constraint": f"{'max_speed_rise' if mode == 'head' else 'max_head_rise'} <= {limit!r}", "limit": limit,
        "law": _law_row(law), "cases": cases, "best_linear": _law_row(opt.best_linear),
        "improvement_over_best_linear": opt.improvement,
        "linear_family": [_law_row(g) for g in opt.linear_family],
        "pareto_two_stage": [_law_row(f) for f in opt.pareto_two_stage],
        "extrapolated_cases": extrapolated,
        "verification": verification, "verification_max_abs_difference": worst_diff,
        "verification_tolerance": VERIFY_TOLERANCE, "members": len(members),
        "load_cases": [{"name": lc.name, "overrides": lc.overrides} for lc in study.load_cases],
        "evaluations": opt.evaluations, "wall_time_s": opt.wall_time_s, "seed": args.seed, "maxiter": args.maxiter,
        "popsize": args.popsize, "bounds": {"closing_time_s": opt.bounds[0], "break_opening": opt.bounds[1],
                                            "break_time_s": opt.bounds[2]},
        "differential_evolution": opt.de_message,
    }
    from hillchart.io.tidy import tidy_floats

    # 12 significant digits like every summary.json, so the verification runs' files match these numbers exactly
    (out / "closure.json").write_text(json.dumps(tidy_floats(doc), indent=2) + "\n", encoding="utf-8")
    worst = max(range(len(study.load_cases)), key=lambda i: getattr(law.cases[i], doc["objective"]))
    (out / "optimum_plant.toml").write_text(optimum_plant_toml(args.plant, study, plant, law.law, worst, out),
                                            encoding="utf-8")
    if not args.no_plot:
        plot_outputs(opt, plant, study.load_cases, out)
    lw = law.law
    print(f"optimize-closure: two-stage law T1 {lw.closing_time_s:.4g} s, break at stroke {lw.break_opening:.4g}, "
          f"T2 {lw.break_time_s:.4g} s: max speed rise {law.max_speed_rise:.4f}, max head rise "
          f"{law.max_head_rise:.4f}; best linear T1 {opt.best_linear.law.closing_time_s:.4g} s: "
          f"{opt.best_linear.max_speed_rise:.4f}, {opt.best_linear.max_head_rise:.4f}; verification by hillsim run "
          f"max |diff| {worst_diff:.3g}; wrote {args.out}")
    if extrapolated:
        where = (f"every run ({len(study.load_cases)} load case(s) x {len(members)} characteristics)"
                 if len(extrapolated) == len(cases) > 1 else ", ".join(extrapolated))
        print(f"optimize-closure: warning: with the optimum the run leaves the characteristics' trusted domain in "
              f"{where}: figures there are extrapolated (closure.json extrapolated_cases)")
    if not worst_diff <= VERIFY_TOLERANCE:
        raise NumericalError(f"verification: hillsim run and the batch differ by {worst_diff:.3g} (> "
                             f"{VERIFY_TOLERANCE:g}); see {out / 'closure.json'}")
    return 0
