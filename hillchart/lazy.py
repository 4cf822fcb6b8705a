"""Public names of a package imported on first use (PEP 562), so importing the package itself stays cheap."""

from __future__ import annotations

import importlib
import sys


def lazy_exports(package: str, table: dict[str, str]):
    """``(__getattr__, __dir__)`` for ``package``: each name of ``table`` (name -> defining module) is imported on
    first access and then cached in the package's namespace, so later accesses skip the hook.

    Examples
    --------
    >>> getattr_, dir_ = lazy_exports("hillchart", {"G_M_S2": "hillchart.constants"})
    >>> getattr_("G_M_S2") > 9.8
    True
    """

    def __getattr__(name: str):
        module = table.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__():
        return sorted(set(vars(sys.modules[package])) | set(table))

    return __getattr__, __dir__
