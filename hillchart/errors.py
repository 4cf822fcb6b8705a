"""Exceptions shared by every hillsim package."""


import re

#: numpy scalar reprs (numpy >= 2 writes ``np.float64(0.0)``, ``np.True_``) and what a message shows instead.
_NUMPY_REPR = re.compile(r"np\.(?:float|int|uint|complex)\d*\(([^()]*)\)|np\.(True|False)_")


def plain_numbers(text: str) -> str:
    """``text`` with numpy scalar reprs written as plain numbers: ``got np.float64(0.0)`` -> ``got 0.0``.

    >>> plain_numbers("torque_nm must be > 0, got np.float64(0.0); flag np.True_")
    'torque_nm must be > 0, got 0.0; flag True'
    """
    return _NUMPY_REPR.sub(lambda m: m.group(1) if m.group(1) is not None else m.group(2), text)


class HillsimError(Exception):
    """Base class of the errors hillsim raises on purpose (the CLI prints them without a traceback). Messages never
    show numpy reprs (see :func:`plain_numbers`), whichever value a check formatted with ``!r``."""

    def __str__(self) -> str:
        return plain_numbers(super().__str__())


class InputError(HillsimError, ValueError):
    """Bad user input: a file, a key, a value or a CLI option. The message names the field, the value and what
    is allowed."""


class NumericalError(HillsimError, RuntimeError):
    """A numerical procedure failed (no convergence, NaN): the message says where and by how much."""
