"""One module per ``hillsim`` sub-command, and what several of them share: ``--set``, reading a plant file and
checking an integer option's range."""

from __future__ import annotations

import sys

#: The seeds a training command takes (``--seed``): numpy's and the compiled Levenberg-Marquardt loop's int32.
SEED_RANGE = (0, 2**31 - 1)

#: The help of ``--set`` in the commands that simulate one plant (``hillsim run``, ``hillsim linearize --plant``).
SET_HELP = ("override a plant-file key; the value is parsed as TOML (repeatable), "
            "e.g. --set penstock.model=\"rigid\" --set scenario.t_end_s=30")


def add_set_option(parser, help: str = SET_HELP) -> None:
    """``--set SECTION.KEY=VALUE`` (repeatable, into ``args.overrides``), read by :func:`load_command_plant`."""
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="SECTION.KEY=VALUE",
                        help=help)


def int_in(option: str, value, low: int, high: int, *, auto: bool = False) -> int:
    """``value`` (an int, or its text) as an integer in ``[low, high]``, or an ``InputError`` naming ``option``, the
    value and the range (``auto``: the option also takes 'auto', handled by the caller, and the message says so).

    Examples
    --------
    >>> int_in("--hidden", "12", 1, 30)
    12
    >>> int_in("--hidden", 0, 1, 30)
    Traceback (most recent call last):
    ...
    hillchart.errors.InputError: --hidden must be an integer in [1, 30], got 0
    """
    from hillchart.errors import InputError

    try:
        number = int(value)
    except (TypeError, ValueError):
        also = " or 'auto'" if auto else ""
        raise InputError(f"{option} must be an integer in [{low}, {high}]{also}, got {value!r}") from None
    if str(number) != str(value).strip() or not low <= number <= high:
        raise InputError(f"{option} must be an integer in [{low}, {high}], got {value!r}")
    return number


def study_note(plant, skipped) -> str:
    """The note a command that does not read a guarantee study's sections prints when the plant file has them.

    Examples
    --------
    >>> study_note("plant.toml", ["limits", "load_cases"])
    'note: plant.toml: [limits] and [[load_cases]] are read by hillsim report and optimize-closure; ignored here'
    >>> study_note("plant.toml", ["load_cases"])
    'note: plant.toml: [[load_cases]] is read by hillsim report and optimize-closure; ignored here'
    """
    names = {"limits": "[limits]", "load_cases": "[[load_cases]]"}
    sections = " and ".join(names.get(name, f"[{name}]") for name in skipped)
    verb = "are" if len(skipped) > 1 else "is"
    return f"note: {plant}: {sections} {verb} read by hillsim report and optimize-closure; ignored here"


def load_command_plant(command: str, path, override_texts=()):
    """The plant of ``path`` with the ``--set`` texts applied (:func:`simulate.config.parse_override`), as every
    command that simulates one plant reads it. A guarantee study's ``[limits]`` and ``[[load_cases]]`` are ignored
    with one note on stderr (``hillsim COMMAND: note: ...``): the same file serves ``hillsim report``."""
    from simulate.config import load_plant, parse_override

    overrides = dict(parse_override(text) for text in override_texts)
    skipped: list[str] = []
    plant = load_plant(path, overrides, skipped=skipped)
    if skipped:
        print(f"hillsim {command}: {study_note(path, skipped)}", file=sys.stderr)
    return plant
