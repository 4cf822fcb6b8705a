"""The one time-loop template, for a plant of one unit or of several (``[[units]]``), written out per plant from its
compiled components (the generated module is cached on disk, see :mod:`simulate.loop.assembly`).

The loop walks the plant: upstream part -> (common conduit -> manifold junction, with several units) -> each unit's
conduit -> its turbine boundary, downstream part, control and shaft. A plant of one unit is a plant with one unit whose
conduit is the plant's penstock (any penstock model) and that has no junction; with several units the plant's
penstock is the common conduit and each unit's conduit its branch (method of characteristics). Per step k -> k+1
(t = k dt):

1. every unit's control: its control vector (guide vanes; with the runner blades, of length two) at t_{k+1} from its
   named signals at t_k (:mod:`simulate.components.signals`), and its shaft: the speed at t_{k+1} from the turbine
   torque at t_k (explicit Euler), in ``n_sub`` sub-steps of dt / n_sub;
2. the upstream head; with several units the common conduit's relation H = C_L + k Q at the manifold, each branch's
   C- line H = C_M,i + B_i Q_i at its inlet, and the junction
   (:func:`simulate.components.hydraulic.junction.manifold_solve`): the manifold head and the common flow;
3. every unit: its conduit's relation H_in = C_L + k Q at the turbine (from the upstream head, or the manifold head),
   its downstream part's H_out = C_M + B_M Q at the runner outlet (0 at the tailwater), the turbine boundary on the
   net head H = (C_L - C_M) + (k - B_M) Q (the unit's ``turbine`` part, the boundary its characteristics' kind
   chose: the pressure loop of the shipped kinds), then the unit's conduit and downstream updates;
4. the common conduit's update (several units), the upstream part; the head envelope of the plant's penstock.

With the method of characteristics at Courant number 1 the manifold and the turbines at t_{k+1} depend only on the
pipes' state at t_k, so the junction and the units are solved one after the other without iteration.

The units are unrolled in the generated text (``u0_...``, ``u1_...``): each unit's components may differ (a governor
on one, a prescribed law on another) and numba sees plain calls. Every unit shares the characteristics kernel (its
parameters are the unit's own, in its turbine part's params), pasted once per module with the pressure loop. The
templates below name no model and no turbine function: the roles are bound to each unit's components, its turbine
boundary included (``u0_turbine_step``, ``u0_turbine_signals``).
"""

from __future__ import annotations

import threading

from simulate.components.registry import LoopTemplate
from simulate.components.turbine import boundary
from simulate.loop.assembly import (_header_lines, _import_line, _modules_of, _turbine_lines, compiled_loop,
                                    level_function, role_function, signal_lines)

#: Bump when the template changes shape (part of every generated file's hash through the source text).
TEMPLATE_VERSION = 3

#: Per-unit series in ``out_units[row, unit, :]``, then the unit's control vector (``controls[0]``: the vane stroke).
UNIT_SERIES = ("speed_rpm", "head_m", "flow_m3_s", "torque_nm")
#: Columns of ``out_manifold[row, :]`` before the per-unit pairs (branch inlet flow, branch inlet head).
MANIFOLD_SERIES = ("manifold_head_m", "manifold_flow_m3_s", "conduit_outlet_flow_m3_s", "conduit_outlet_head_m")
#: The parts of a unit whose ``record`` function writes extra timeseries columns, in column order (after the
#: upstream part's columns).
UNIT_RECORDING_KINDS = ("shaft", "control", "downstream", "conduit")

_HEAD = '''
@_jit
def time_loop(k0, k1, dt, n_sub, stride, up, up_s, units, out_units, out_iter, out_signals, env_max, env_min,
              diag{junction_args}):
    """Steps k0 .. k1-1 of a plant with {n} unit(s) (t = k dt); every ``stride``-th step stored in row
    (k + 1) // stride of the out arrays. Returns (status, k): 0 and k1, or the failing unit's turbine-boundary status
    and step (``diag[8]``: the unit)."""
    h = dt / n_sub
'''

_STEP = '''    for k in range(k0, k1):
        t = k * dt
        t_next = (k + 1) * dt
        for j in range(n_sub):
            t_sub = t + j * h if j > 0 else t
            t_sub_next = t + (j + 1) * h if j < n_sub - 1 else t_next
{substep}
        upstream = upstream_head(up, up_s)
{junction}
{turbines}
{after}
        if (k + 1) % stride == 0:
            row = (k + 1) // stride
{records}
    return 0, k1
'''

#: One unit's sub-step: the named signals, the control step, the shaft step ({i}: the unit's index).
_UNIT_SUBSTEP = '''{fill}
            controls{i} = u{i}_control_step(ctl{i}, ctl{i}_s, sig{i}, t_sub, t_sub_next, h)
{after_control}
            speed{i} = u{i}_shaft_step(sh{i}, sh{i}_s, torque{i}, t_sub, h)'''

#: One unit's conduit, downstream part and turbine boundary ({head}: the head at the conduit's upstream end).
_UNIT_TURBINE = '''        c_l{i}, slope{i} = u{i}_conduit_relation(cd{i}, cd{i}_s, {head})
        c_m{i}, b_m{i} = u{i}_downstream_relation(dn{i}, dn{i}_s)
        status, it{i} = u{i}_turbine_step(tb{i}, tb{i}_s, c_l{i} - c_m{i}, slope{i} - b_m{i}, speed{i}, controls{i},
                                          diag)
        if status != 0:
            diag[0] = t_next
            diag[8] = {i}
            return status, k
        head{i}, flow{i}, torque{i} = u{i}_turbine_signals(tb{i}, tb{i}_s)
{after_turbine}
        outlet{i} = c_m{i} + b_m{i} * flow{i}
        inlet{i} = head{i} + outlet{i}
        u{i}_conduit_update(cd{i}, cd{i}_s, {head}, inlet{i}, flow{i})
        u{i}_downstream_update(dn{i}, dn{i}_s, outlet{i}, flow{i})'''

_UNIT_RECORDS = '''            out_units[row, {i}, 0] = speed{i}
            out_units[row, {i}, 1] = head{i}
            out_units[row, {i}, 2] = flow{i}
            out_units[row, {i}, 3] = torque{i}
            for c in range(controls{i}.size):
                out_units[row, {i}, 4 + c] = controls{i}[c]
            out_iter[row, {i}] = it{i}'''

#: With several units: the common conduit's relation, the branches' inlet lines and the junction ...
_JUNCTION = '''        c_l, slope = penstock_relation(pen, pen_s, upstream)
{inlets}
        h_man, q_man = manifold_solve(c_l, slope, man_c, man_b, man_q)'''
#: ... and after the units, the common conduit's update, the upstream part, the conduit's envelope.
_JUNCTION_AFTER = '''        penstock_update(pen, pen_s, upstream, h_man, q_man)
        upstream_step(up, up_s, penstock_inlet_flow(pen, pen_s), dt)
        penstock_envelope(pen, pen_s, upstream, h_man, env_max, env_min)'''
_JUNCTION_RECORDS = '''            out_manifold[row, 0] = h_man
            out_manifold[row, 1] = q_man
            out_manifold[row, 2] = conduit_outlet_flow(pen, pen_s)
            out_manifold[row, 3] = conduit_outlet_head(pen, pen_s)'''
#: With one unit: its conduit is the penstock, fed by the upstream part; the envelope is the penstock's.
_SINGLE_AFTER = '''        upstream_step(up, up_s, u0_conduit_inlet_flow(cd0, cd0_s), dt)
        u0_conduit_envelope(cd0, cd0_s, upstream, inlet0, env_max, env_min)'''

#: alias in the loop -> (key of the unit's parts, function role); the conduit's envelope only with one unit
UNIT_ROLES = {
    "control_step": ("control", "step"),
    "shaft_speed": ("shaft", "speed"),
    "shaft_step": ("shaft", "step"),
    "shaft_power": ("shaft", "power"),
    "shaft_grid_frequency": ("shaft", "grid_frequency"),
    "conduit_relation": ("conduit", "relation"),
    "conduit_update": ("conduit", "update"),
    "conduit_inlet_flow": ("conduit", "inlet_flow"),
    "downstream_relation": ("downstream", "relation"),
    "downstream_update": ("downstream", "update"),
    "turbine_step": ("turbine", "step"),
    "turbine_signals": ("turbine", "signals"),
}
#: alias -> (key of a unit's parts, function role) of a branch (several units): its C- line at the manifold, with the
#: branch's own friction model (:func:`simulate.components.hydraulic.penstock.moc_inlet_relation`, bound by its builder)
BRANCH_ROLES = {"conduit_inlet_relation": ("conduit", "inlet_relation")}
#: alias -> (key of the common parts, function role); the penstock's only with several units (the common conduit)
COMMON_ROLES = {
    "upstream_head": ("upstream", "head"),
    "upstream_step": ("upstream", "step"),
    "penstock_relation": ("penstock", "relation"),
    "penstock_update": ("penstock", "update"),
    "penstock_inlet_flow": ("penstock", "inlet_flow"),
    "penstock_envelope": ("penstock", "envelope"),
}


def _unit_roles(several: bool) -> dict:
    return {**UNIT_ROLES, **(BRANCH_ROLES if several else {"conduit_envelope": ("conduit", "envelope")})}


def _common_roles(several: bool) -> dict:
    return COMMON_ROLES if several else {a: r for a, r in COMMON_ROLES.items() if r[0] == "upstream"}


def _templates(units: list[dict], several: bool) -> list:
    """The distinct :class:`simulate.components.registry.LoopTemplate` functions the units' parts name, in order."""
    found = []
    for parts in units:
        for kind, role in _unit_roles(several).values():
            func = role_function(parts[kind], role)
            if isinstance(func, LoopTemplate) and func not in found:
                found.append(func)
    return found


def loop_source(common: dict, units: list[dict], characteristics, pressure_loop: str, compiled: bool,
                cache: bool = True, counted: bool = False) -> tuple[str, list[str]]:
    """Text of the loop module and the module names it imports.

    ``common``: the plant's ``upstream`` part and, for a plant with ``[[units]]``, its ``penstock`` (the common
    conduit, which branches at the manifold junction: present for a plant with ``[[units]]`` of any number);
    ``units``: one dict of parts per unit (``conduit``: the unit's pipe, the plant's penstock for a plant of one unit,
    else its branch; ``downstream``, ``control``, ``shaft``, ``turbine``: its boundary); ``characteristics``: their
    compiled form (one kernel for every unit, pasted once); ``counted``: the loop with reference counting (see
    :class:`simulate.loop.assembly.CompiledLoop`).
    """
    from simulate.components.hydraulic import junction

    several = "penstock" in common  # the common conduit and the junction (a plant with [[units]], even of one)
    lines = _header_lines(compiled, cache, counted)
    lines[0] += f" (template {TEMPLATE_VERSION})"
    modules = {"simulate.components.turbine.boundary", "simulate.components.signals"}
    if several:
        modules.add(junction.__name__)
        for alias, func in (("manifold_solve", junction.manifold_solve),
                            ("conduit_inlet_head", junction.moc_inlet_head),
                            ("conduit_outlet_flow", junction.moc_outlet_flow),
                            ("conduit_outlet_head", junction.moc_outlet_head)):
            lines.append(_import_line(func, alias, inline=True))
    # the characteristics' kernels and the pressure loop, once for every unit, with the functions a unit's part
    # asks to be pasted beside them (the pressure-loop boundary's step)
    lines += _turbine_lines(characteristics, pressure_loop, _templates(units, several), modules)
    for alias, (kind, role) in _common_roles(several).items():
        func = common[kind].functions[role]
        lines.append(_import_line(func, alias, inline=True))
        modules.update(_modules_of(func))
    level = level_function(common["upstream"], units)
    if level is not None:  # the named signal upstream_level_m, only where a control reads it
        lines.append(_import_line(level, "upstream_level", inline=True))
        modules.update(_modules_of(level))
    records, column = [], 0

    def record(part, alias: str, args: str) -> None:
        nonlocal column
        if not part.signals:
            return
        func = part.functions["record"]
        lines.append(_import_line(func, alias, inline=True))
        modules.update(_modules_of(func))
        records.append(f"            {alias}({args}, out_signals[row, {column}:{column + len(part.signals)}])")
        column += len(part.signals)

    record(common["upstream"], "upstream_record", "up, up_s")
    unpack, init, substep, inlets, turbines = [], [], [], [], []
    names = {"up": "upstream" if not several else "h_man"}
    for i, parts in enumerate(units):
        for alias, (kind, role) in _unit_roles(several).items():
            func = role_function(parts[kind], role)
            lines.append(_import_line(func, f"u{i}_{alias}", inline=True))
            modules.update(_modules_of(func))
        unpack.append(f"    tb{i}, tb{i}_s, cd{i}, cd{i}_s, dn{i}, dn{i}_s, ctl{i}, ctl{i}_s, sh{i}, sh{i}_s, "
                      f"sig{i} = units[{i}]")
        init.append(f"    torque{i} = u{i}_turbine_signals(tb{i}, tb{i}_s)[2]")
        fill, after_control, after_turbine = signal_lines(parts["control"].hooks.reads, i)
        substep.append(_UNIT_SUBSTEP.format(i=i, fill=fill, after_control=after_control))
        if several:
            inlets.append(f"        man_c[{i}], man_b[{i}] = u{i}_conduit_inlet_relation(cd{i}, cd{i}_s)")
        turbines.append(_UNIT_TURBINE.format(i=i, head=names["up"], after_turbine=after_turbine))
        records.append(_UNIT_RECORDS.format(i=i))
        for kind in UNIT_RECORDING_KINDS:
            abbreviation = {"shaft": "sh", "control": "ctl", "downstream": "dn", "conduit": "cd"}[kind]
            record(parts[kind], f"u{i}_{kind}_record", f"{abbreviation}{i}, {abbreviation}{i}_s")
        if several:
            base = len(MANIFOLD_SERIES) + 2 * i
            records += [f"            out_manifold[row, {base}] = u{i}_conduit_inlet_flow(cd{i}, cd{i}_s)",
                        f"            out_manifold[row, {base + 1}] = conduit_inlet_head(cd{i}, cd{i}_s)"]
    if several:
        unpack.append("    man_c, man_b, man_q = man")
        records = _JUNCTION_RECORDS.splitlines() + records
    head = _HEAD.replace("{n}", str(len(units))).replace(
        "{junction_args}", ", pen, pen_s, man, out_manifold" if several else "")
    body = head + "\n".join(unpack + init) + "\n"
    body += (_STEP.replace("{substep}", "\n".join(substep))
             .replace("{junction}\n", _JUNCTION.replace("{inlets}", "\n".join(inlets)) + "\n" if several else "")
             .replace("{turbines}", "\n".join(turbines))
             .replace("{after}", _JUNCTION_AFTER if several else _SINGLE_AFTER)
             .replace("{records}", "\n".join(records)))
    lines.append(body)
    return "\n".join(lines) + "\n", sorted(modules)


def signal_columns(common: dict, units: list[dict]) -> list[tuple[int | None, object]]:
    """``(unit index or None for the common upstream part, part)`` of every part that records columns, in the
    column order of ``out_signals`` the generated loop writes."""
    out = [(None, common["upstream"])] if common["upstream"].signals else []
    for i, parts in enumerate(units):
        out += [(i, parts[kind]) for kind in UNIT_RECORDING_KINDS if parts[kind].signals]
    return out


#: compiled ``time_loop`` by the identity of what its source is made of (:func:`_assembly_key`): a process running
#: many cases of one structure writes and fingerprints the loop's text once (reading the templates' source with
#: ``inspect`` costs about 7 ms a run, more than a shipped-plant case's loop)
_ASSEMBLED: dict[tuple, object] = {}
_ASSEMBLING = threading.RLock()


def _assembly_key(common: dict, units: list[dict], characteristics, pressure_loop: str) -> tuple:
    """What :func:`loop_source` reads: the components' functions (by object), the recording columns, the signals
    each control reads, the characteristics' kernels and the pressure loop. Template files do not change within a
    process."""
    several = "penstock" in common

    def recorded(part):
        return (part.functions["record"], len(part.signals)) if part.signals else None

    key = [tuple(common[kind].functions[role] for kind, role in _common_roles(several).values()),
           recorded(common["upstream"]), level_function(common["upstream"], units)]
    for parts in units:
        key.append((tuple(role_function(parts[kind], role) for kind, role in _unit_roles(several).values()),
                    tuple(recorded(parts[kind]) for kind in UNIT_RECORDING_KINDS), parts["control"].hooks.reads))
    return (tuple(key), characteristics.identity(), pressure_loop, boundary.SOLVERS[pressure_loop])


def assemble(common: dict, units: list[dict], characteristics, pressure_loop: str, *, compiled: bool = True):
    """The ``time_loop`` function for these parts (see :func:`loop_source`), compiled and disk-cached, or plain
    Python. Thread-safe: runs on several threads (:mod:`simulate.loop.parallel`) write and import a loop module
    once."""
    if not compiled:
        source, _ = loop_source(common, units, characteristics, pressure_loop, False)
        namespace = {"__name__": "hillsim_loop_python"}
        exec(compile(source, "<hillsim loop>", "exec"), namespace)
        namespace["kernel"] = characteristics.python_kernel()
        return namespace["time_loop"]
    key = _assembly_key(common, units, characteristics, pressure_loop)
    found = _ASSEMBLED.get(key)
    if found is not None:
        return found
    with _ASSEMBLING:
        if key not in _ASSEMBLED:
            _ASSEMBLED[key] = compiled_loop(lambda cache, counted: loop_source(
                common, units, characteristics, pressure_loop, True, cache=cache, counted=counted))
        return _ASSEMBLED[key]
