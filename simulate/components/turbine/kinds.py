"""Kinds of turbine characteristics, registered in :data:`simulate.components.registry.CHARACTERISTICS`.

Every entry of the registry is a :class:`CharacteristicKind`, one contract for all of them:

* a kind chosen by its registry word (``by_word = True``: ``turbine.characteristics = "ideal"``) loads itself from
  the plant's turbine section, :meth:`CharacteristicKind.load`;
* a kind read from a nets.json (``by_word = False``) answers whether a file is its own from the file's parsed
  content, :meth:`CharacteristicKind.owns`, and builds its characteristics from it, :meth:`CharacteristicKind.read`.
  The file is read once, and the first registered kind that claims it reads it.
* a characteristics object a caller hands the simulator (a sweep's cases, an ensemble member, a user's own nets) is
  offered to every kind, :meth:`CharacteristicKind.adopt`; the first that adopts it gives its kind (its boundary,
  its figures), :func:`adopt_characteristics`.

How the loop evaluates the characteristics a kind returns is their compiled form
(:mod:`simulate.components.turbine.evaluation`), chosen by what the object offers; a kind whose kernel needs its own
loop lines gives its characteristics a ``compiled_characteristics()`` method.

The kind also chooses the turbine boundary its characteristics are solved with every step,
:attr:`CharacteristicKind.boundary`: the builder of the unit's part of kind ``"turbine"``
(:func:`simulate.components.turbine.component.build_turbine_part`). The kinds that ship use the pressure loop of the
BP hill-chart paper on Q11(N11, a) (:func:`simulate.components.turbine.boundary.build_pressure_loop`); a kind whose
boundary is solved otherwise (a four-quadrant pump-turbine on the Suter angle, a valve in closed form) names its own.

A kind added from outside the package is one module with a :class:`CharacteristicKind` object and one line,
``CHARACTERISTICS.register("my-turbine", "my_package.my_turbine:KIND")``.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

from hillchart.errors import InputError
from simulate.components.registry import CHARACTERISTICS


#: The inputs a nets.json file's flow block names, in order, for two- and three-input nets.
TWO_INPUTS = ["n11", "opening"]
THREE_INPUTS = ["n11", "opening", "blade_angle"]

class CharacteristicKind:
    """The contract of an entry of :data:`~simulate.components.registry.CHARACTERISTICS` (module docstring).

    Attributes
    ----------
    by_word : bool
        True: chosen by its registry word; False: recognized in a nets.json by :meth:`owns`.
    description : str
        What the kind is, for messages (for a file kind: what a file of its own holds).
    label : str
        The characteristics' name in a command's output (a word kind).
    opening_unit : str
        The unit of the opening its characteristics take (a word kind; a file kind's object carries its own).
    boundary : str
        ``"module:function"`` of the builder of its turbine boundary, ``build(inputs) -> CompiledPart`` (kind
        ``"turbine"``; ``inputs``: a :class:`simulate.components.turbine.component.BoundaryInputs`), whose
        functions by role the loop calls: ``step(p, s, c_l_m, k_s_m2, speed_rpm, controls, diag) -> (status,
        iterations)`` solves head, flow and torque against H = C_L + k Q (k in m per m^3/s; status 0 when it
        converged), ``signals(p, s) -> (head m, flow m^3/s, torque N*m)`` of the last step. Default: the pressure
        loop (:func:`simulate.components.turbine.boundary.build_pressure_loop`).
    """

    by_word: bool = False
    description: str = ""
    label: str = ""
    opening_unit: str = "chart units"
    boundary: str = "simulate.components.turbine.boundary:build_pressure_loop"
    #: True for characteristics over all four quadrants (a pump mode, reverse flow and rotation).
    four_quadrant: bool = False

    def load(self, turbine, *, key: str = "turbine.characteristics"):
        """The characteristics of a word kind, from the plant's turbine section ``turbine`` (a
        :class:`simulate.config.TurbineConfig`, or None where no plant is given); ``key``: the name of the setting
        for messages."""
        raise TypeError(f"{type(self).__name__} is read from a nets.json; it defines no load()")

    def owns(self, document) -> bool:
        """True when the parsed nets.json ``document`` (any JSON value) holds this kind's characteristics."""
        return False

    def read(self, document, path: Path):
        """The characteristics from a ``document`` this kind :meth:`owns`, read from ``path`` (for messages)."""
        raise TypeError(f"{type(self).__name__} is chosen by its word; it defines no read()")

    def adopt(self, characteristics):
        """The simulator's form of a caller's own ``characteristics`` object when it is of this kind (the object
        :meth:`read` or :meth:`load` returns, or the library object a file of this kind holds), else None. A
        caller's object thereby runs on its kind's :attr:`boundary` and gives its kind's figures, as the plant's own
        does (:func:`adopt_characteristics`)."""
        return None


def ideal_from_rated(turbine):
    """:class:`hillchart.characteristics.IdealTurbine` from the rated values: q11_max = Q_r / (D1^2 sqrt(H_r)) at full
    stroke, efficiency P_r / (rho g Q_r H_r)."""
    from hillchart.characteristics import IdealTurbine

    q11_max = turbine.rated_flow_m3_s / (turbine.runner_diameter_m ** 2 * math.sqrt(turbine.rated_head_m))
    return IdealTurbine(q11_max_m3_s=q11_max, opening_max=turbine.opening_max, efficiency=turbine.rated_efficiency)


class IdealKind(CharacteristicKind):
    """The ideal turbine from the plant's own rated values (:func:`ideal_from_rated`)."""

    by_word = True
    description = "the ideal turbine from the plant's rated values"
    label = "ideal turbine (the plant's rated values)"

    def load(self, turbine, *, key="turbine.characteristics"):
        if turbine is None:
            raise InputError(f"{key} = 'ideal' needs the plant's rated values")
        if getattr(turbine, "step_up", None) is not None:
            raise InputError(f"turbine.step_up converts a model test's chart to the prototype; {key} = \"ideal\" is "
                             f"built from the prototype's own rated values: remove [turbine.step_up] or give a "
                             f"nets.json")
        return ideal_from_rated(turbine)


class SyntheticFrancisKind(CharacteristicKind):
    """The exact synthetic Francis turbine the shipped chart was drawn from."""

    by_word = True
    description = "the exact synthetic Francis turbine"
    label = "synthetic Francis turbine (exact)"
    opening_unit = "mm"

    def load(self, turbine, *, key="turbine.characteristics"):
        from hillchart.synthetic.francis import SyntheticFrancis

        return SyntheticFrancis()


class SyntheticBulbKind(CharacteristicKind):
    """The exact synthetic double-regulated bulb turbine (three inputs: n11, guide-vane angle, blade angle)."""

    by_word = True
    description = "the exact synthetic double-regulated bulb turbine"
    label = "synthetic bulb turbine (exact, double regulated)"
    opening_unit = "deg"

    def load(self, turbine, *, key="turbine.characteristics"):
        from hillchart.synthetic.bulb import SyntheticBulb

        return SyntheticBulb()


def _flow_inputs(document):
    """The ``flow.inputs`` list of a nets.json document (None where the document has none)."""
    flow = document.get("flow") if isinstance(document, dict) else None
    return flow.get("inputs") if isinstance(flow, dict) else None


def _named(path: Path, build, document):
    """``build(document)`` with an InputError naming the file ``path``."""
    try:
        return build(document)
    except InputError as exc:
        raise InputError(f"{path}: {str(exc).removeprefix('nets.json: ')}") from None


NETS_FORMAT = "hillsim.nets"


class TwoInputNetsKind(CharacteristicKind):
    """Nets of a single-regulated turbine, Q11 and M11 of (n11, opening) (:class:`hillchart.nets.hill_nets.
    HillNets`); a hillsim.nets file whose flow block names no other inputs is one (the nets' loader then says what
    else is wrong with it)."""

    description = "two-input nets (format hillsim.nets, inputs n11, opening)"

    def owns(self, document) -> bool:
        return (isinstance(document, dict) and document.get("format") == NETS_FORMAT
                and _flow_inputs(document) in (None, TWO_INPUTS))

    def read(self, document, path):
        from hillchart.nets.hill_nets import HillNets

        return _named(path, HillNets.from_dict, document)


class ThreeInputNetsKind(CharacteristicKind):
    """Nets of a double-regulated turbine, Q11 and M11 of (n11, opening, blade angle) (:class:`hillchart.fccm.
    double_regulated.DoubleRegulatedNets`)."""

    description = "three-input nets (format hillsim.nets, inputs n11, opening, blade_angle)"

    def owns(self, document) -> bool:
        return (isinstance(document, dict) and document.get("format") == NETS_FORMAT
                and _flow_inputs(document) == THREE_INPUTS)

    def read(self, document, path):
        from hillchart.fccm.double_regulated import DoubleRegulatedNets

        return _named(path, DoubleRegulatedNets.from_dict, document)


IDEAL = IdealKind()
SYNTHETIC_FRANCIS = SyntheticFrancisKind()
SYNTHETIC_BULB = SyntheticBulbKind()
TWO_INPUT_NETS = TwoInputNetsKind()
THREE_INPUT_NETS = ThreeInputNetsKind()


def kind_of(name: str) -> CharacteristicKind:
    """The registered kind ``name`` (an InputError names the registered ones)."""
    kind = CHARACTERISTICS.builder(name)
    if not isinstance(kind, CharacteristicKind):
        raise TypeError(f"turbine.characteristics kind {name!r} is registered as {type(kind).__name__}, not a "
                        f"CharacteristicKind")
    return kind


def adopt_characteristics(characteristics) -> tuple[str | None, object]:
    """``(kind, characteristics)``: the first registered kind that adopts the caller's ``characteristics``
    (:meth:`CharacteristicKind.adopt`) and the object in the form it runs in; ``(None, characteristics)`` for an
    object no kind adopts (it runs on the default boundary, the pressure loop on Q11(N11, a))."""
    for name in CHARACTERISTICS.names():
        adopted = kind_of(name).adopt(characteristics)
        if adopted is not None:
            return name, adopted
    return None, characteristics


def word_kinds() -> tuple[str, ...]:
    """The words ``turbine.characteristics`` may hold instead of a nets.json path."""
    return tuple(name for name in CHARACTERISTICS.names() if kind_of(name).by_word)


def nets_path(spec: str, base_dir=None) -> Path | None:
    """The file ``turbine.characteristics = spec`` names (relative to ``base_dir``), None for a registry word."""
    if spec in word_kinds():
        return None
    path = Path(spec)
    return path if path.is_absolute() or base_dir is None else Path(base_dir) / path


def file_stamp(path: Path) -> tuple:
    """What tells a file's version without reading it: (inode, size, modification time in ns)."""
    stat = os.stat(path)
    return stat.st_ino, stat.st_size, stat.st_mtime_ns


def load_kind(spec: str, *, turbine=None, base_dir=None, key: str = "turbine.characteristics"):
    """``(name, characteristics, path, stamp)``: the kind that reads ``spec`` (a registry word, or the kind that owns
    the nets.json at that path, read once), its characteristics, the file and its :func:`file_stamp` (None for a
    word); with ``turbine.step_up`` the model's characteristics converted to the prototype
    (:func:`simulate.components.turbine.step_up.apply_step_up`)."""
    path = nets_path(spec, base_dir)
    stamp = None
    if path is None:
        name = spec
        characteristics = kind_of(spec).load(turbine, key=key)
    else:
        if not path.is_file():
            where = " (relative to the plant file)" if base_dir is not None else ""
            words = ", ".join(f'"{w}"' for w in word_kinds())
            raise InputError(f"{key} = {spec!r}: nets file {str(path)!r} does not exist; give {words} or the path "
                             f"of a nets.json{where}")
        from hillchart.nets.hill_nets import read_nets_json

        stamp = file_stamp(path)
        document = read_nets_json(path)
        name = next((n for n in CHARACTERISTICS.names() if not kind_of(n).by_word and kind_of(n).owns(document)),
                    None)
        if name is None:
            kinds = "; ".join(f"{n}: {kind_of(n).description}" for n in CHARACTERISTICS.names()
                              if not kind_of(n).by_word)
            found = document.get("format") if isinstance(document, dict) else type(document).__name__
            raise InputError(f"{key} = {spec!r}: no registered kind of characteristics reads {str(path)!r} (format "
                             f"{found!r}, flow inputs {_flow_inputs(document)!r}); the kinds read: {kinds}")
        characteristics = kind_of(name).read(document, path)
    if turbine is not None and getattr(turbine, "operating_mode", "turbine") == "pump" \
            and not kind_of(name).four_quadrant:
        fours = ", ".join(repr(n) for n in CHARACTERISTICS.names() if kind_of(n).four_quadrant)
        raise InputError(f"turbine.operating_mode = 'pump' needs characteristics over all four quadrants (the kinds "
                         f"{fours}); {key} = {spec!r} is of kind {name!r}, a turbine's chart")
    if turbine is not None and getattr(turbine, "step_up", None) is not None:
        from simulate.components.turbine.step_up import apply_step_up

        characteristics = apply_step_up(characteristics, turbine)
    return name, characteristics, path, stamp


def resolve_characteristics(spec: str, *, turbine=None, base_dir=None, key: str = "turbine.characteristics"):
    """The one resolver of characteristics for the plant file and every command: a registry word (``"ideal"``, which
    needs ``turbine``, ``"synthetic"``, ``"synthetic-bulb"``) or a nets.json path read by the kind that owns it
    (two-input nets, or three-input ones with inputs n11, opening, blade_angle); see :func:`load_kind`."""
    return load_kind(spec, turbine=turbine, base_dir=base_dir, key=key)[1]
