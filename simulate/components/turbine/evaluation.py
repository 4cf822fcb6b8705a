"""How the time loop evaluates the turbine characteristics: their compiled form.

The generated loop (:mod:`simulate.loop.assembly`) calls three globals and names no characteristics:
``kernel(params, n11, controls) -> (q11, dq11_dn11, m11, dm11_dn11)``, ``flow_kernel(params, n11, controls)``
(what the iterations of a pressure loop that reads Q11 only call: ``(q11, dq11_dn11, ...)``) and
``torque_kernel(params, n11, controls) -> m11`` (the torque at the converged head). A compiled form writes the lines
that define them (:meth:`CompiledCharacteristics.loop_lines`) and gives the Python kernel the uncompiled loop runs
(:meth:`CompiledCharacteristics.python_kernel`); the assembly asks it and compares nothing.

Three forms ship, chosen by what the characteristics object offers (:func:`compile_characteristics`):

* :class:`ControlKernel`: ``numba_control_kernel()``, a kernel on the control vector (a double-regulated turbine:
  guide vane and runner blade);
* :class:`TwoInputKernel`: ``numba_kernel()``, a kernel on (N11, a) (the nets, the ideal and synthetic turbines):
  the loop reads the guide vane ``controls[0]``;
* :class:`PythonKernel`: only the four Python methods; the same generated loop runs as plain Python.

An object with ``compiled_characteristics()`` returns its own form (a subclass of :class:`CompiledCharacteristics`
with its own :meth:`~CompiledCharacteristics.loop_lines`): the seam for characteristics whose kernel reads other
inputs (e.g. a four-quadrant table on the angle of the Suter transform).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, ClassVar


@dataclass(frozen=True)
class CompiledCharacteristics:
    """The characteristics as the loop evaluates them: ``kernel`` and its ``params`` (a tuple of arrays), and, where
    the characteristics offer them, kernels without derivatives the loop reads instead of the whole one.

    Attributes
    ----------
    kernel : callable
        The characteristics' kernel in the form's own signature.
    params : tuple
        Its parameters, passed to the loop as ``ch``.
    flow_kernel : callable or None
        On the control vector: ``flow_kernel(params, n11, controls) -> (q11, dq11_dn11, ...)`` on the same params
        (:class:`ControlKernel`).
    flow_value, torque_value : callable or None
        ``flow_value(params, n11, a) -> q11`` and ``torque_value(params, n11, a) -> m11``, the two-input kernel's
        values without derivatives (``numba_value_kernels()``); on the control vector ``torque_value(params, n11,
        controls) -> m11`` (``numba_control_torque_kernel()``).
    """

    kernel: Callable
    params: tuple
    flow_kernel: Callable | None = None
    flow_value: Callable | None = None
    torque_value: Callable | None = None
    #: True when ``kernel`` is numba-compiled (the loop can be compiled too)
    jitted: ClassVar[bool] = True

    def loop_lines(self, import_line: Callable[[Callable, str], str], modules: set) -> list[str]:
        """Lines of the loop module that define ``kernel``, ``flow_kernel`` and ``torque_kernel``; ``import_line(func,
        alias)`` writes the line that binds a module-level function as a global; the modules the lines import are
        added to ``modules``."""
        raise NotImplementedError(f"{type(self).__name__} must define loop_lines")

    def python_kernel(self) -> Callable:
        """``kernel(params, n11, controls) -> (q11, dq11_dn11, m11, dm11_dn11)`` as plain Python (the loop run
        uncompiled)."""
        raise NotImplementedError(f"{type(self).__name__} must define python_kernel")

    def identity(self) -> tuple:
        """What the loop's text depends on: the form and its functions (a key of the assembled loops)."""
        return type(self), self.kernel, self.flow_kernel, self.flow_value, self.torque_value


def _fallback(name: str, expression: str) -> list[str]:
    """``name(params, n11, controls)`` as an expression of the whole ``kernel``."""
    return ["@_jit_inner", f"def {name}(params, n11, controls):", f"    return {expression}"]


def _on_guide_vane(py_kernel: Callable) -> Callable:
    """A two-input kernel ``(params, n11, a) -> (q11, dq11_dn11, dq11_da, m11, dm11_dn11, dm11_da)`` read on the
    guide vane ``controls[0]``."""
    def two_input(params, n11, controls):
        out = py_kernel(params, n11, controls[0])
        return out[0], out[1], out[3], out[4]

    return two_input


class TwoInputKernel(CompiledCharacteristics):
    """A numba kernel ``(params, n11, a) -> (q11, dq11_dn11, dq11_da, m11, dm11_dn11, dm11_da)`` read on the guide
    vane ``controls[0]``."""

    def loop_lines(self, import_line, modules):
        modules.add(self.kernel.__module__)
        lines = [import_line(self.kernel, "_characteristics_kernel"),
                 "@_jit_inner", "def kernel(params, n11, controls):",
                 "    out = _characteristics_kernel(params, n11, controls[0])",
                 "    return out[0], out[1], out[3], out[4]"]
        for name, value, form, fallback in (
                ("flow_kernel", self.flow_value, "({},)", "kernel(params, n11, controls)"),
                ("torque_kernel", self.torque_value, "{}", "kernel(params, n11, controls)[2]")):
            if value is None:
                lines += _fallback(name, fallback)
                continue
            modules.add(value.__module__)
            call = f"_{name}_value(params, n11, controls[0])"
            lines += [import_line(value, f"_{name}_value"), "@_jit_inner", f"def {name}(params, n11, controls):",
                      f"    return {form.format(call)}"]
        return lines

    def python_kernel(self):
        return _on_guide_vane(getattr(self.kernel, "py_func", self.kernel))


class ControlKernel(CompiledCharacteristics):
    """A numba kernel on the control vector ``(params, n11, controls) -> (q11, dq11_dn11, m11, dm11_dn11)``."""

    def loop_lines(self, import_line, modules):
        modules.add(self.kernel.__module__)
        lines = [import_line(self.kernel, "_characteristics_kernel"), "kernel = _characteristics_kernel"]
        for name, func, fallback in (("flow_kernel", self.flow_kernel, "kernel(params, n11, controls)"),
                                     ("torque_kernel", self.torque_value, "kernel(params, n11, controls)[2]")):
            if func is None:
                lines += _fallback(name, fallback)
            else:
                modules.add(func.__module__)
                lines.append(import_line(func, name))
        return lines

    def python_kernel(self):
        return getattr(self.kernel, "py_func", self.kernel)


class PythonKernel(CompiledCharacteristics):
    """No numba kernel: the four Python methods on (N11, a) (:func:`hillchart.characteristics.scalar_kernel`), set
    as the loop's ``kernel`` after its module is executed; the loop runs as Python."""

    jitted: ClassVar[bool] = False

    def loop_lines(self, import_line, modules):
        return (["kernel = None  # set after import: a Python function"]
                + _fallback("flow_kernel", "kernel(params, n11, controls)")
                + _fallback("torque_kernel", "kernel(params, n11, controls)[2]"))

    def python_kernel(self):
        return _on_guide_vane(self.kernel)


def compile_characteristics(characteristics) -> CompiledCharacteristics:
    """The compiled form of ``characteristics`` (module docstring): its own ``compiled_characteristics()``, else
    :class:`ControlKernel`, :class:`TwoInputKernel` or :class:`PythonKernel` by the kernels it offers."""
    own = getattr(characteristics, "compiled_characteristics", None)
    if own is not None:
        compiled = own()
        if not isinstance(compiled, CompiledCharacteristics):
            raise TypeError(f"{type(characteristics).__name__}.compiled_characteristics() must return a "
                            f"CompiledCharacteristics, got {type(compiled).__name__}")
        return compiled
    if hasattr(characteristics, "numba_control_kernel"):
        kernel, params = characteristics.numba_control_kernel()
        flow = getattr(characteristics, "numba_control_flow_kernel", lambda: None)()
        torque = getattr(characteristics, "numba_control_torque_kernel", lambda: None)()
        return ControlKernel(kernel, tuple(params), flow_kernel=flow, torque_value=torque)
    from hillchart.characteristics import scalar_kernel

    kernel, params, jitted = scalar_kernel(characteristics)
    if not jitted:
        return PythonKernel(kernel, tuple(params))
    flow, torque = characteristics.numba_value_kernels() \
        if hasattr(characteristics, "numba_value_kernels") else (None, None)
    return TwoInputKernel(kernel, tuple(params), flow_value=flow, torque_value=torque)
