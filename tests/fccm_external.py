"""The real data in ``../shared/external/`` as hillchart.fccm test-table folders (validation only, never shipped).

The files are found by ``tests/external_charts.py``'s :func:`require_external`, which skips cleanly when they are
absent (and checks that the calling test carries the ``external`` marker).
"""

from __future__ import annotations

import csv
from pathlib import Path

from tests.external_charts import require_external

BULB_137KW = "bulb_137kW_gv_hill_chart.csv"
KAPLAN_LISZKA = "liszka_kaplan_blade_angle_hill_chart.csv"


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(line for line in handle if not line.startswith("#")))


def write_bulb_137kw_table(dest) -> Path:
    """EGAT 137 kW fixed-blade bulb (D = 0.4 m, 1000 r/min): controls guide vane and head; mechanical power and
    efficiency (generator efficiency 0.9 assumed by SOURCES.md); n11 and Q11 left for the loader to derive."""
    src = require_external(BULB_137KW) / BULB_137KW
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    (dest / "table.toml").write_text('name = "EGAT 137 kW bulb turbine (fixed blades), Kaeng Krachan rig"\n'
                                     'runner_diameter_m = 0.4\nspeed_rpm = 1000.0\n'
                                     'controls = ["guide_vane_deg", "head_m"]\n', encoding="utf-8")
    with (dest / "table.csv").open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(["guide_vane_deg", "head_m", "flow_m3_s", "power_kw", "efficiency", "n11_file", "q11_file"])
        for r in _rows(src):
            writer.writerow([r["gv_deg"], r["head_m"], r["discharge_m3s"], r["mechanical_power_kW"], r["mech_eff"],
                             r["n11_derived_rpm"], r["Q11_derived_m3s"]])
    return dest


def write_kaplan_table(dest) -> Path:
    """Liszka et al. Kaplan chart (unit quantities): blade angle and n11 as the chart's variables."""
    src = require_external(KAPLAN_LISZKA) / KAPLAN_LISZKA
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    (dest / "table.toml").write_text('name = "Kaplan chart of Liszka et al. (digitized)"\n'
                                     'controls = ["blade_angle_deg", "n11_rpm"]\n', encoding="utf-8")
    with (dest / "table.csv").open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(["blade_angle_deg", "n11_rpm", "q11_m3_s", "efficiency"])
        for r in _rows(src):
            writer.writerow([r["Blade Angle"], r["n11"], r["Q11"], r["Efficiency"]])
    return dest
