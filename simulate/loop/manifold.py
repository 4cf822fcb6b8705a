"""The time loop of a plant with several units, generated like the single-unit loop (:mod:`simulate.loop.assembly`).

The loop walks the plant: upstream part -> common conduit -> manifold junction -> one branch per unit -> that unit's
turbine boundary, control and shaft. Per step k -> k+1:

1. every unit's control and shaft (in ``n_sub`` sub-steps), from its speed and its turbine torque at t_k;
2. the common conduit's relation H = C_L + k Q at the manifold, each branch's C- line H = C_M,i + B_i Q_i at its
   inlet, and the junction (:func:`simulate.components.hydraulic.junction.manifold_solve`): the manifold head and the
   common flow;
3. every unit's turbine boundary against its branch's C+ line (the pressure loop of the single-unit loop);
4. the branches' updates (upstream boundary: the manifold head), the common conduit's update (downstream boundary: the
   manifold head and the common flow), the upstream part.

With the method of characteristics at Courant number 1 the manifold and the turbines at t_{k+1} depend only on the
pipes' state at t_k, so the junction and the units are solved one after the other without iteration.

The units are unrolled in the generated text (``u0_...``, ``u1_...``): each unit's components may differ (a
governor on one, a prescribed law on another) and numba sees plain calls. Every unit shares the characteristics
kernel (its parameters are the unit's own).
"""

from __future__ import annotations

from simulate.loop.assembly import (_ROLES, _header_lines, _import_line, _modules_of, _turbine_lines, compiled_loop,
                                    role_function, signal_lines)

#: Bump when the template changes shape (part of every generated file's hash through the source text).
MULTI_TEMPLATE_VERSION = 3

#: Per-unit series in ``out_units[row, unit, :]``.
UNIT_SERIES = ("speed_rpm", "head_m", "flow_m3_s", "torque_nm", "opening")
#: Columns of ``out_manifold[row, :]`` before the per-unit pairs (branch inlet flow, branch inlet head).
MANIFOLD_SERIES = ("manifold_head_m", "manifold_flow_m3_s", "conduit_outlet_flow_m3_s", "conduit_outlet_head_m")

_HEAD = '''
@_jit
def time_loop(k0, k1, dt, n_sub, stride, up, up_s, pen, pen_s, units, man, out_units, out_iter, out_manifold,
              out_signals, env_max, env_min, diag):
    """Steps k0 .. k1-1 of a plant with {n} units (t = k dt); every ``stride``-th step stored in row (k + 1) // stride.
    Returns (status, k): 0 and k1, or the failing unit's turbine-boundary status and step (``diag[8]``: the unit)."""
    h = dt / n_sub
    c_m, b_in, q_in = man
'''

_STEP = '''    for k in range(k0, k1):
        t = k * dt
        t_next = (k + 1) * dt
        for j in range(n_sub):
            t_sub = t + j * h if j > 0 else t
            t_sub_next = t + (j + 1) * h if j < n_sub - 1 else t_next
{substep}
        upstream = upstream_head(up, up_s)
        c_l, slope = penstock_relation(pen, pen_s, upstream)
{inlets}
        h_man, q_man = manifold_solve(c_l, slope, c_m, b_in, q_in)
{turbines}
        penstock_update(pen, pen_s, upstream, h_man, q_man)
        upstream_step(up, up_s, penstock_inlet_flow(pen, pen_s), dt)
        penstock_envelope(pen, pen_s, upstream, h_man, env_max, env_min)
        if (k + 1) % stride == 0:
            row = (k + 1) // stride
            out_manifold[row, 0] = h_man
            out_manifold[row, 1] = q_man
            out_manifold[row, 2] = conduit_outlet_flow(pen, pen_s)
            out_manifold[row, 3] = conduit_outlet_head(pen, pen_s)
{records}
    return 0, k1
'''

#: role -> (key of the unit's parts, function role): the single-unit loop's control and shaft roles, and the branch
_UNIT_ROLES = {**{alias: role for alias, role in _ROLES.items() if role[0] in ("control", "shaft")},
               "branch_relation": ("branch", "relation"), "branch_update": ("branch", "update")}
#: the single-unit loop's roles of the common upstream and penstock
_COMMON_ROLES = {alias: role for alias, role in _ROLES.items() if role[0] in ("upstream", "penstock")}


def multi_loop_source(common: dict, units: list[dict], characteristics, pressure_loop: str, compiled: bool,
                      cache: bool = True, counted: bool = False) -> tuple[str, list[str]]:
    """Text of the loop module for the common parts (``upstream``, ``penstock``) and one dict of parts per unit
    (``branch``, ``control``, ``shaft``), and the module names it imports."""
    from simulate.components.hydraulic import junction

    lines = _header_lines(compiled, cache, counted)
    lines[0] += f" (several units, template {MULTI_TEMPLATE_VERSION})"
    modules = {"simulate.components.turbine.boundary", "simulate.components.signals", junction.__name__}
    for alias, func in (("manifold_solve", junction.manifold_solve),
                        ("branch_inlet_relation", junction.moc_inlet_relation),
                        ("branch_inlet_head", junction.moc_inlet_head),
                        ("conduit_outlet_flow", junction.moc_outlet_flow),
                        ("conduit_outlet_head", junction.moc_outlet_head)):
        lines.append(_import_line(func, alias, inline=True))
    for alias, (kind, role) in _COMMON_ROLES.items():
        func = common[kind].functions[role]
        lines.append(_import_line(func, alias, inline=True))
        modules.add(func.__module__)
    records = []
    if common["upstream"].signals:
        func = common["upstream"].functions["record"]
        lines.append(_import_line(func, "upstream_record", inline=True))
        modules.add(func.__module__)
        records.append(f"            upstream_record(up, up_s, out_signals[row, 0:{len(common['upstream'].signals)}])")
    unpack, init, substep, inlets, turbines = [], [], [], [], []
    base = len(MANIFOLD_SERIES)
    for i, parts in enumerate(units):
        for alias, (kind, role) in _UNIT_ROLES.items():
            func = role_function(parts[kind], role)
            lines.append(_import_line(func, f"u{i}_{alias}", inline=True))
            modules.update(_modules_of(func))
        func = parts["branch"].functions["inlet_flow"]
        lines.append(_import_line(func, f"u{i}_branch_inlet_flow", inline=True))
        unpack.append(f"    tb{i}, tb{i}_s, ch{i}, br{i}, br{i}_s, ctl{i}, ctl{i}_s, sh{i}, sh{i}_s, sig{i} = "
                      f"units[{i}]")
        init.append(f"    torque{i} = turbine_signals(tb{i}_s)[2]")
        # the unit's named signals at t_sub (simulate.components.signals), as in the single-unit loop
        before, after_control, after_turbine = signal_lines(parts["control"].hooks.reads, i)
        substep += [before,
                    f"            controls{i} = u{i}_control_step(ctl{i}, ctl{i}_s, sig{i}, t_sub, t_sub_next, h)",
                    after_control,
                    f"            speed{i} = u{i}_shaft_step(sh{i}, sh{i}_s, torque{i}, t_sub, h)"]
        inlets.append(f"        c_m[{i}], b_in[{i}] = branch_inlet_relation(br{i}, br{i}_s)")
        turbines += [f"        c_l{i}, slope{i} = u{i}_branch_relation(br{i}, br{i}_s, h_man)",
                     f"        status, it{i} = turbine_step(tb{i}, ch{i}, tb{i}_s, c_l{i}, slope{i}, speed{i}, "
                     f"controls{i}, diag)",
                     "        if status != 0:",
                     "            diag[0] = t_next",
                     f"            diag[8] = {i}",
                     "            return status, k",
                     f"        head{i}, flow{i}, torque{i} = turbine_signals(tb{i}_s)",
                     after_turbine,
                     f"        u{i}_branch_update(br{i}, br{i}_s, h_man, head{i}, flow{i})"]
        records += [f"            out_units[row, {i}, 0] = speed{i}",
                    f"            out_units[row, {i}, 1] = head{i}",
                    f"            out_units[row, {i}, 2] = flow{i}",
                    f"            out_units[row, {i}, 3] = torque{i}",
                    f"            out_units[row, {i}, 4] = controls{i}[0]",
                    f"            out_iter[row, {i}] = it{i}",
                    f"            out_manifold[row, {base + 2 * i}] = u{i}_branch_inlet_flow(br{i}, br{i}_s)",
                    f"            out_manifold[row, {base + 2 * i + 1}] = branch_inlet_head(br{i}, br{i}_s)"]
    lines += _turbine_lines(characteristics, pressure_loop, modules)
    body = _HEAD.replace("{n}", str(len(units))) + "\n".join(unpack + init) + "\n"
    body += (_STEP.replace("{substep}", "\n".join(substep)).replace("{inlets}", "\n".join(inlets))
             .replace("{turbines}", "\n".join(turbines)).replace("{records}", "\n".join(records)))
    lines.append(body)
    return "\n".join(lines) + "\n", sorted(modules)


def assemble_units(common: dict, units: list[dict], characteristics, pressure_loop: str, *, compiled: bool = True):
    """The ``time_loop`` of a plant with several units (compiled and disk-cached, or plain Python)."""
    if not compiled:
        source, _ = multi_loop_source(common, units, characteristics, pressure_loop, compiled)
        namespace = {"__name__": "hillsim_loop_python"}
        exec(compile(source, "<hillsim loop>", "exec"), namespace)
        namespace["kernel"] = characteristics.python_kernel()
        return namespace["time_loop"]
    return compiled_loop(lambda cache, counted: multi_loop_source(
        common, units, characteristics, pressure_loop, True, cache=cache, counted=counted))
