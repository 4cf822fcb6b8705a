"""Comparing written chart folders with the shipped one: exact on one machine, to the last written digit across CPUs.

numpy's vectorised exp/log/pow may differ by an ulp between CPUs (AVX2, AVX-512 and NEON code paths); that can move a
rounding tie of a written number by one unit of its last digit, and by nothing more. A change of the model or of the
noise moves the numbers by far more (the tests that use this show such a failing case beside the passing one).
"""

from pathlib import Path

CHART_FILES = ("chart.toml", "flow.csv", "efficiency.csv", "runaway.csv", "truth.csv")


def last_place(field: str) -> float:
    """One unit in the last written digit of a CSV field ("0.3171" -> 1e-4, "2.5e-05" -> 1e-6, "12" -> 1)."""
    mantissa, _, exponent = field.lower().partition("e")
    return 10.0 ** (int(exponent or 0) - len(mantissa.partition(".")[2]))


def assert_csv_matches(ours: Path, reference: Path) -> None:
    """Same header and row count; every number within one unit of the reference's last written digit."""
    lines_ours, lines_ref = ours.read_text().splitlines(), reference.read_text().splitlines()
    assert lines_ours[0] == lines_ref[0] and len(lines_ours) == len(lines_ref), reference.name
    for row, (a_line, b_line) in enumerate(zip(lines_ours[1:], lines_ref[1:], strict=True), start=2):
        for a, b in zip(a_line.split(","), b_line.split(","), strict=True):
            assert abs(float(a) - float(b)) <= 1.000001 * last_place(b), (reference.name, row, a, b)


def assert_chart_matches(ours: Path, reference: Path, names=CHART_FILES) -> None:
    """chart.toml as text, the CSVs by :func:`assert_csv_matches`."""
    for name in names:
        if name.endswith(".csv"):
            assert_csv_matches(ours / name, reference / name)
        else:
            assert (ours / name).read_text() == (reference / name).read_text(), name
