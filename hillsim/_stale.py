"""Ignore the cache-only folders an earlier installation left in ``site-packages``.

Releases of hillsim before the user cache folder (:mod:`hillchart.cache`) let numba write its cache files beside the
installed modules. ``pip`` does not know those files, so replacing a wheel install by an editable one leaves folders
such as ``site-packages/simulate/components/__pycache__`` behind with no ``__init__.py``. Python's path finder, which
runs before an editable install's finder, takes such a folder for a namespace package and hides the real one.

:func:`import_shadowed_packages` runs before anything else of hillsim is imported (stdlib only): for each of the
project's top-level packages that the path finder resolves to a namespace package while another finder has the real,
regular package, it imports the real one and says so in one line on stderr, naming the folder to delete.
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import sys

#: The installed top-level packages besides ``hillsim`` (pyproject.toml's packages.find).
PACKAGES = ("hillchart", "simulate", "data_synthetic")


def _regular_spec(name: str):
    """The spec of ``name`` from the finders after the path finder (an editable install's), if it is a regular
    package."""
    for finder in sys.meta_path:
        if finder is importlib.machinery.PathFinder or not hasattr(finder, "find_spec"):
            continue
        try:
            spec = finder.find_spec(name, None)
        except (ImportError, AttributeError, ValueError):
            continue
        if spec is not None and spec.origin not in (None, "namespace") and spec.loader is not None:
            return spec
    return None


def import_shadowed_packages(packages=PACKAGES, stream=None) -> list[str]:
    """Import each of ``packages`` that a leftover cache-only folder would shadow; return the folders ignored."""
    ignored = []
    for name in packages:
        if name in sys.modules:
            continue
        spec = importlib.machinery.PathFinder.find_spec(name)
        if spec is None or spec.origin not in (None, "namespace"):
            continue  # not found by the path finder, or a regular package: nothing shadows it
        real = _regular_spec(name)
        if real is None:
            continue
        module = importlib.util.module_from_spec(real)
        sys.modules[name] = module
        try:
            real.loader.exec_module(module)
        except BaseException:
            del sys.modules[name]
            raise
        folders = list(spec.submodule_search_locations or [])
        ignored.extend(folders)
        print(f"hillsim: ignoring {', '.join(folders)}: compiled-code cache left by an earlier installation "
              f"(safe to delete)", file=stream or sys.stderr)
    return ignored
