"""Exceptions shared by every hillsim package."""


class HillsimError(Exception):
    """Base class of the errors hillsim raises on purpose (the CLI prints them without a traceback)."""


class InputError(HillsimError, ValueError):
    """Bad user input: a file, a key, a value or a CLI option. The message names the field, the value and what
    is allowed."""


class NumericalError(HillsimError, RuntimeError):
    """A numerical procedure failed (no convergence, NaN): the message says where and by how much."""
