"""The repository's scripts (benchmarks/*.py, docs/*.py) as modules, for the tests that check what they print."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def load_script(name: str, folder: str = "benchmarks"):
    """The script ``REPO/folder/name.py`` as a module, loaded once per process and registered in ``sys.modules``
    under ``name``: its dataclasses look their module up by name, numba's disk cache reloads a compiled function by
    importing its module, and a campaign's worker processes find its functions there. Each pytest-xdist worker loads
    it for itself (a test that imported it by name would fail in a worker where no other test had loaded it)."""
    module = sys.modules.get(name)
    if module is not None:
        return module
    spec = importlib.util.spec_from_file_location(name, REPO / folder / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module


def write_between_markers(page: Path, markers: tuple[str, str], text: str) -> None:
    """Put ``text`` between the two ``markers`` lines of the docs page ``page`` (a benchmark's ``--write-docs``);
    an error, and the page untouched, when the markers are missing; says what it wrote."""
    doc = page.read_text(encoding="utf-8")
    start, end = markers
    at, until = doc.find(start + "\n"), doc.find(end)
    if at < 0 or until < at:
        raise SystemExit(f"{page}: the markers {markers} are missing")
    partial = page.with_name(page.name + ".partial")  # the page replaced whole, never left half written
    partial.write_text(f"{doc[:at]}{start}\n{text}\n{doc[until:]}", encoding="utf-8")
    partial.replace(page)
    print(f"wrote {page}")
