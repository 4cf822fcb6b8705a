"""Assemble the time loop from compiled components, cached on disk: the machinery under the one loop template of
:mod:`simulate.loop.generator` (the module header, the components' functions bound as globals, the turbine's
templates, the compiled loop and its disk cache).

numba caches a function on disk only if none of its arguments is a function (a dispatcher argument makes the
function uncacheable: "dynamic globals"). So the components are not passed to the loop as arguments: for each
combination of (characteristics kernel, pressure loop, and each unit's conduit, downstream, control, shaft and
turbine boundary with the plant's upstream part) this module writes a small Python module that imports the
components' module-level numba functions as globals, pastes the kernel-dependent templates of
:mod:`simulate.components.turbine.boundary` (the pressure loop, with the kernel bound as a global, and the
pressure-loop boundary's step, a :class:`~simulate.components.registry.LoopTemplate`), and defines ``time_loop`` with
``numba.njit(cache=True, nogil=True, _nrt=False)``, the components' step functions inlined into it (see
:func:`_header_lines` for why, and :class:`CompiledLoop` for a component that needs numba's reference counting).
The module's file name is a hash of
its own text and of the source files of every module it imports (numba's cache checks only the file that defines the
function, so a change in a component's source must produce a new file), so a second run of the same combination
loads the compiled loop from numba's cache instead of compiling it.

Generated modules live in ``$HILLSIM_CACHE_DIR`` (default ``~/.cache/hillsim/loops``; a temporary directory when
that is not writable).

The same text runs uncompiled (``jit=False`` or characteristics without a numba kernel): the module is executed with
an identity decorator, so there is one source of the loop either way.
"""

from __future__ import annotations

import hashlib
import importlib.util
import inspect
import os
import sys
import textwrap
import threading
import types
from pathlib import Path

import numba

from simulate.components.registry import Bound, LoopTemplate
from simulate.components.signals import SHAFT_DEFAULTS, shaft_function, upstream_function
from simulate.components.turbine import boundary

#: Bump when the loop template changes shape (part of every generated file's hash).
TEMPLATE_VERSION = 9

def role_function(part, role: str):
    """The part's function ``role``; a shaft's optional signal functions (``power``, ``grid_frequency``) default to
    NaN (:data:`simulate.components.signals.SHAFT_DEFAULTS`)."""
    if part.kind == "shaft" and role in SHAFT_DEFAULTS:
        return shaft_function(part, role)
    return part.functions[role]


def level_function(upstream, units: list[dict]):
    """The upstream part's ``level`` function when a unit's control reads ``upstream_level_m`` (its NaN default for a
    part without one, which :func:`simulate.components.signals.check_provided` refuses before the run); None when no
    control reads it: the loop then neither imports nor calls it."""
    if any("upstream_level_m" in parts["control"].hooks.reads for parts in units):
        return upstream_function(upstream, "level")
    return None


def signal_lines(reads, unit: int | None = None) -> tuple[str, str, str]:
    """The loop's lines that fill the named signals the control ``reads``
    (:data:`simulate.components.signals.SIGNALS`): before the control step, after it (the vane stroke) and after the
    turbine step (the net head); ``unit``: the unit's index in the loop of several units (its names ``sig0``,
    ``u0_shaft_speed``, ...). A signal no control reads is not computed (``pass`` keeps each block a statement)."""
    n, f = ("", "") if unit is None else (str(unit), f"u{unit}_")
    sh = f"sh{n}, sh{n}_s"
    fills = {"speed_rpm": f"speed_now{n}", "electrical_power_mw": f"{f}shaft_power({sh}, t_sub)",
             "turbine_power_mw": f"torque{n} * speed_now{n} * RPM_NM_TO_MW",
             "grid_frequency_hz": f"{f}shaft_grid_frequency({sh})", "upstream_level_m": "upstream_level(up, up_s)"}
    sub, step = " " * 12, " " * 8
    before = [f"{sub}speed_now{n} = {f}shaft_speed({sh})"]
    before += [f"{sub}sig{n}[{name.upper()}] = {value}" for name, value in fills.items() if name in reads]
    after_control = [f"{sub}sig{n}[VANE_STROKE] = controls{n}[0]"] if "vane_stroke" in reads else [f"{sub}pass"]
    after_turbine = [f"{step}sig{n}[NET_HEAD_M] = head{n}"] if "net_head_m" in reads else [f"{step}pass"]
    return "\n".join(before), "\n".join(after_control), "\n".join(after_turbine)


def _template(func, drop_first: bool) -> str:
    """Source of a template function without its decorator (and without its first parameter when asked)."""
    src = textwrap.dedent(inspect.getsource(func))
    lines = [ln for ln in src.splitlines() if not ln.startswith("@")]
    src = "\n".join(lines) + "\n"
    if drop_first:
        head, rest = src.split("(", 1)
        first, rest = rest.split(",", 1)
        src = head + "(" + rest.lstrip()
    return "@_jit_inner\n" + src


def _import_line(func, alias: str, *, inline: bool = False) -> str:
    """The line that binds ``func`` as the loop global ``alias``; ``inline``: a component's function, compiled
    into the loop from its source (see :func:`_header_lines`). A :class:`simulate.components.registry.Bound`
    function is compiled from its source with the named globals rebound (``_bind``); a
    :class:`simulate.components.registry.LoopTemplate` is the function :func:`_turbine_lines` pasted by its name."""
    if isinstance(func, LoopTemplate):
        return f"{alias} = {func.func.__name__}"
    if isinstance(func, Bound):
        lines = [_import_line(func.func, f"_{alias}_unbound")]
        names = []
        for i, (name, target) in enumerate(func.names):
            # inlined like the component's own step: a bound function compiled on its own inside the loop without
            # reference counting may not return an array that is not its argument (a prescribed vane law returning
            # its state's control vector to the blades' step), inlined it may
            lines.append(_import_line(target, f"_{alias}_name{i}", inline=True))
            names.append(f"{name}=_{alias}_name{i}")
        lines.append(f"{alias} = _inline_bound(_bind(_{alias}_unbound, {', '.join(names)}))")
        return "\n".join(lines)
    module, name = func.__module__, func.__name__
    mod = sys.modules.get(module) or importlib.import_module(module)
    if getattr(mod, name, None) is not func:
        raise TypeError(f"{module}.{name} is not a module-level function; a component's numba functions must be "
                        f"importable by name so the assembled loop can be cached")
    if inline:
        return f"from {module} import {name} as _{alias}_compiled\n{alias} = _inline(_{alias}_compiled)"
    return f"from {module} import {name} as {alias}"


def _modules_of(func) -> tuple[str, ...]:
    """The modules a component's function is made of (a bound one: its own and those of the functions bound)."""
    return func.modules if isinstance(func, (Bound, LoopTemplate)) else (func.__module__,)


def _header_lines(compiled: bool, cache: bool, counted: bool = False) -> list[str]:
    lines = ["# generated by simulate.loop.assembly: do not edit", "import math", "import types", "import numba",
             "from simulate.components.turbine.boundary import OK, NO_POSITIVE_HEAD, NAN, NOT_CONVERGED, "
             "quadratic_flow",
             "from simulate.components.turbine.boundary import ROUNDOFF_TOLERANCE, FALLBACK_DAMPING",
             "from simulate.components.signals import SPEED_RPM, ELECTRICAL_POWER_MW, TURBINE_POWER_MW, NET_HEAD_M, "
             "VANE_STROKE, GRID_FREQUENCY_HZ, UPSTREAM_LEVEL_M, RPM_NM_TO_MW"]
    if compiled and not counted:
        # The templates (pressure loop, turbine step) and the components' step functions are inlined into
        # time_loop at numba-IR level, and the whole is compiled without reference counting (_nrt=False): every
        # call of a component unpacks its tuples of parameter and state arrays, and with reference counting each
        # array unpacked is an atomic increment and decrement, which LLVM cannot move out of the time loop. The
        # loop allocates nothing and every array it touches is an argument that outlives the call, so there is
        # nothing to count. Measured on the shipped plant (benchmarks/bench_loop_step.py): 630 -> 440 ns a step,
        # results bit-identical. Functions the loop calls are compiled for it the same way (numba passes the flag
        # on); a test checks that a run leaves no reference behind.
        lines += [f"_jit = numba.njit(cache={cache}, nogil=True, _nrt=False)",
                  f"_jit_inner = numba.njit(cache={cache}, inline='always', _nrt=False)",
                  "def _inline(dispatcher):",
                  "    return numba.njit(inline='always', _nrt=False)(getattr(dispatcher, 'py_func', dispatcher))",
                  "_inline_bound = _inline"]
    elif compiled:  # the counted loop (CompiledLoop's fallback): the components called as compiled
        lines += [f"_jit = numba.njit(cache={cache}, nogil=True)",
                  f"_jit_inner = numba.njit(cache={cache}, inline='always')",
                  "def _inline(dispatcher):",
                  "    return dispatcher",
                  "_inline_bound = numba.njit"]
    else:
        lines += ["def _jit(f):", "    return f", "_jit_inner = _jit", "_inline = _jit", "_inline_bound = _jit"]
    # a Bound component function (simulate.components.registry.Bound): its Python source with named globals rebound
    lines += ["def _bind(dispatcher, **names):",
              "    func = getattr(dispatcher, 'py_func', dispatcher)",
              "    return types.FunctionType(func.__code__, {**func.__globals__, **names}, func.__name__,",
              "                              func.__defaults__, func.__closure__)"]
    return lines


def _turbine_lines(characteristics, pressure_loop: str, templates, modules: set) -> list[str]:
    """The characteristics' kernels as the globals ``kernel``, ``flow_kernel`` and ``torque_kernel`` (their compiled
    form writes them: :meth:`simulate.components.turbine.evaluation.CompiledCharacteristics.loop_lines`), the
    pressure-loop templates as ``pressure_loop`` and ``newton_loop``, and the source of each
    :class:`simulate.components.registry.LoopTemplate` of ``templates`` (the pressure-loop boundary's
    :func:`simulate.components.turbine.boundary.turbine_step`), which calls them; adds the modules they import to
    ``modules``."""
    lines = characteristics.loop_lines(_import_line, modules)
    solver = boundary.SOLVERS[pressure_loop]
    solver_source = _template(getattr(solver, "py_func", solver), drop_first=True)  # plain with NUMBA_DISABLE_JIT
    if pressure_loop in boundary.FLOW_ONLY_SOLVERS:
        call = "kernel(params, "
        if solver_source.count(call) != 1:
            raise RuntimeError(f"pressure loop {pressure_loop!r}: expected one {call!r} in its template")
        solver_source = solver_source.replace(call, "flow_kernel(params, ")
    lines.append(solver_source.replace(f"def {solver.__name__}(", "def pressure_loop("))
    newton = boundary.SOLVERS["newton"]  # the turbine step's last fallback
    newton_source = _template(getattr(newton, "py_func", newton), drop_first=True)
    lines.append(newton_source.replace(f"def {newton.__name__}(", "def newton_loop("))
    pasted = {}
    for template in templates:
        name = template.func.__name__
        if pasted.setdefault(name, template.func) is not template.func:
            raise TypeError(f"two loop templates named {name!r} ({pasted[name].__module__} and "
                            f"{template.func.__module__}): a template is pasted by its name")
        lines.append(_template(template.func, drop_first=False))
        modules.update(template.modules)
    return lines


class CompiledLoop:
    """The compiled ``time_loop`` of a generated module, called as the function itself.

    The loop is compiled without reference counting (see :func:`_header_lines`). numba refuses to compile that way a
    component whose step function allocates or returns a new array (a ``TypingError`` at the first call): such a
    component (one registered from outside the package, say) then runs in the loop ``counted()`` assembles, the
    same loop with reference counting, about 1.5 times as long a step on the shipped plant and otherwise the same."""

    def __init__(self, loop, counted):
        self._loop, self._counted = loop, counted
        self.counted = False

    def __call__(self, *args):
        try:
            return self._loop(*args)
        except numba.core.errors.TypingError:
            if self.counted:
                raise
            self.counted = True
            self._loop = self._counted()
            return self._loop(*args)


def _cache_dir() -> Path:
    from hillchart.cache import first_writable, temporary_cache

    root = os.environ.get("HILLSIM_CACHE_DIR")
    candidates = [Path(root)] if root else []
    candidates.append(Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "hillsim" / "loops")
    candidates.append(temporary_cache("hillsim-loops"))
    path = first_writable(candidates)
    if path is None:
        raise OSError("no writable directory for the compiled-loop cache; set HILLSIM_CACHE_DIR")
    return path


def _fingerprint(source: str, modules: list[str]) -> str:
    h = hashlib.sha256()
    h.update(f"{TEMPLATE_VERSION} numba {numba.__version__} {sys.version_info[:2]}".encode())
    h.update(source.encode())
    for name in sorted(_with_compiled_dependencies(modules)):
        mod = sys.modules.get(name) or importlib.import_module(name)
        h.update(Path(mod.__file__).read_bytes())
    return h.hexdigest()[:20]


def _with_compiled_dependencies(modules: list[str]) -> set[str]:
    """``modules`` and the project modules whose compiled functions they import (e.g. the schedules a governor
    calls), so that editing any of them makes a new loop."""
    names = set(modules)
    for name in modules:
        mod = sys.modules.get(name) or importlib.import_module(name)
        for value in vars(mod).values():
            if isinstance(value, numba.core.registry.CPUDispatcher):
                owner = value.py_func.__module__
                if owner.split(".")[0] in ("simulate", "hillchart") and owner in sys.modules:
                    names.add(owner)
    return names


_LOADED: dict[str, types.ModuleType] = {}
_ASSEMBLING = threading.RLock()
#: :class:`CompiledLoop` by the fingerprint of its module (:func:`_fingerprint`)
_COMPILED: dict[str, "CompiledLoop"] = {}


def compiled_loop(make_source) -> CompiledLoop:
    """The :class:`CompiledLoop` of the module ``make_source(cache, counted) -> (source, modules)`` generates:
    written under the cache directory and imported (:func:`_load`; one :class:`CompiledLoop` per module, so a
    fallback found once is kept), or, when a module it imports has no source file (a kernel defined
    interactively), compiled in memory."""
    def load(counted: bool):
        source, modules = make_source(True, counted)
        if all(getattr(sys.modules.get(m), "__file__", None) for m in modules):
            return _load(source, modules).time_loop
        source, _ = make_source(False, counted)
        namespace = {"__name__": "hillsim_loop_uncached"}
        exec(compile(source, "<hillsim loop>", "exec"), namespace)
        return namespace["time_loop"]

    source, modules = make_source(True, False)
    if not all(getattr(sys.modules.get(m), "__file__", None) for m in modules):
        return CompiledLoop(load(False), lambda: load(True))
    key = _fingerprint(source, modules)  # the text and the imported modules' files: an edited component is new
    with _ASSEMBLING:
        if key not in _COMPILED:
            _COMPILED[key] = CompiledLoop(_load(source, modules, key).time_loop, lambda: load(True))
        return _COMPILED[key]


def _load(source: str, modules: list[str], key: str | None = None) -> types.ModuleType:
    """The generated module of ``source``, written under the cache directory (by ``key``, its :func:`_fingerprint`
    when the caller has it: a hash of its text and of the modules it imports) and imported, so numba's disk cache
    finds its ``time_loop`` again."""
    key = _fingerprint(source, modules) if key is None else key
    if key in _LOADED:
        return _LOADED[key]
    path = _cache_dir() / f"hillsim_loop_{key}.py"
    if not path.is_file() or path.read_text(encoding="utf-8") != source:
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(source, encoding="utf-8")
        os.replace(tmp, path)  # concurrent runs write the same text; the rename keeps the file whole
    name = f"hillsim_loop_{key}"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    _LOADED[key] = module
    return module
