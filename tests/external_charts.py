"""Turn the real charts in ``../shared/external/`` into hillsim chart folders (validation only, never shipped).

Tests that use these call :func:`require_external`, which skips cleanly when the folder is absent.
"""

from __future__ import annotations

import csv
import os
from pathlib import Path

import pytest

#: ``<repo>/../shared/external``; ``HILLSIM_EXTERNAL_DIR`` overrides it (e.g. for a git worktree elsewhere).
EXTERNAL_DIR = Path(os.environ.get("HILLSIM_EXTERNAL_DIR", Path(__file__).resolve().parents[2] / "shared" / "external"))
SAYANO_LINES = "sayano_shushenskaya_francis_opening_lines.csv"
SAYANO_CONTOURS = "sayano_shushenskaya_francis_efficiency_contours.csv"


#: The test being set up (set by tests/conftest.py), so that :func:`require_external` can check its marker.
CURRENT_TEST = None


def require_external(*names: str) -> Path:
    """The external folder, or skip the calling test when it (or one of ``names``) is absent.

    A test that reads external data must carry ``@pytest.mark.external`` (so ``-m "not external"`` leaves it out):
    one that does not is an error here, not a silent dependency."""
    if CURRENT_TEST is not None and CURRENT_TEST.get_closest_marker("external") is None:
        raise AssertionError(f"{CURRENT_TEST.nodeid} reads ../shared/external: mark it @pytest.mark.external")
    for name in names:
        if not (EXTERNAL_DIR / name).is_file():
            pytest.skip(f"external data {EXTERNAL_DIR / name} is absent")
    return EXTERNAL_DIR


def _data_rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as handle:
        lines = [line for line in handle if not line.startswith("#")]
    return list(csv.DictReader(lines))


def write_sayano_chart(dest) -> Path:
    """Sayano-Shushenskaya Francis (D1 = 6.77 m, a0 max 58 mm, Q11 in l/s) as a chart folder, no runaway file.

    Rows with ``padding=1`` (artificial corner points) and the efficiency-0 boundary rows are dropped, as
    ``SOURCES.md`` advises.
    """
    src = require_external(SAYANO_LINES, SAYANO_CONTOURS)
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    (dest / "chart.toml").write_text(
        'name = "Sayano-Shushenskaya Francis (digitized by R. Yuldashev)"\n'
        'opening_unit = "mm"\nopening_max = 58.0\nq11_unit = "l/s"\nefficiency_unit = "fraction"\n'
        "runner_diameter_m = 6.77\n",
        encoding="utf-8",
    )
    with (dest / "flow.csv").open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(["opening", "n11", "q11"])
        for row in _data_rows(src / SAYANO_LINES):
            writer.writerow([row["a0_mm"], row["n11_rpm"], row["Q11_lps"]])
    with (dest / "efficiency.csv").open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(["efficiency", "n11", "q11"])
        for row in _data_rows(src / SAYANO_CONTOURS):
            if row["padding"].strip() == "1" or float(row["eta"]) == 0.0:
                continue
            writer.writerow([row["eta"], row["n11_rpm"], row["Q11_lps"]])
    return dest


#: The ZZ680 Kaplan runner's combined hill chart as its digitizer's workbook (not shipped: no licence): the file
#: ``.m/Dynamic Programming/zz680.xlsx`` of github.com/ShouqingChen1/
#: Dynamic-Simulation-Method-for-Hydropower-Station-Water-Energy-Calculation-and-Unit-Selection, sha256
#: 1c60ce3cfd279a1fe907bf05f0762fafb312f4defd53a2e710f264b69773be15.
ZZ680_WORKBOOK = "zz680.xlsx"
#: Points kept of each efficiency contour of the workbook (its contours are traced densely, up to 1,400 points each).
CONTOUR_POINTS = 40


def write_kaplan_workbook_chart(workbook, dest, *, opening_max: float = 60.0) -> Path:
    """A chart folder from a Kaplan combined hill chart digitized as the ZZ680 workbook is: sheet ``alpha`` rows
    ``N11, Q11 (l/s), guide-vane opening (mm)`` (a first row without numbers), sheet ``eta`` rows ``N11, Q11 (l/s),
    efficiency`` under a header. Each contour keeps :data:`CONTOUR_POINTS` of its rows, evenly spaced in the order
    traced (``numpy.linspace`` over its row indices, rounded), so that the efficiency surface is not fitted to one
    contour's thousand points. Reads the workbook with openpyxl (an error saying so when it is not installed)."""
    import numpy as np

    try:
        import openpyxl
    except ImportError:
        raise ImportError("reading a .xlsx workbook needs openpyxl: pip install openpyxl") from None
    book = openpyxl.load_workbook(workbook, read_only=True, data_only=True)

    def numbers(sheet):
        rows = [row[:3] for row in book[sheet].iter_rows(values_only=True)]
        return np.array([row for row in rows if all(isinstance(v, (int, float)) for v in row)], float)

    lines, contours = numbers("alpha"), numbers("eta")
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    (dest / "chart.toml").write_text(
        'name = "ZZ680 Kaplan combined hill chart (digitized from the Chinese turbine handbook by others)"\n'
        f'opening_unit = "mm"\nopening_max = {opening_max}\nq11_unit = "l/s"\nefficiency_unit = "fraction"\n',
        encoding="utf-8")
    flow = ["opening,n11,q11"] + [f"{a:g},{n:g},{q:g}" for n, q, a in lines]
    efficiency = ["efficiency,n11,q11"]
    for level in np.unique(contours[:, 2]):
        rows = contours[contours[:, 2] == level]
        for n, q, eta in rows[np.unique(np.linspace(0, len(rows) - 1, CONTOUR_POINTS).round().astype(int))]:
            efficiency.append(f"{eta:g},{n:g},{q:g}")
    (dest / "flow.csv").write_text("\n".join(flow) + "\n", encoding="utf-8")
    (dest / "efficiency.csv").write_text("\n".join(efficiency) + "\n", encoding="utf-8")
    return dest
