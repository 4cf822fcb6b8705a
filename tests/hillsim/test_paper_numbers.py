"""The papers' numbers through our models (benchmarks/paper_numbers.py; the docs page holds its output as a generated
block, checked by tests/test_docs.py)."""

from pathlib import Path

import numpy as np
import pytest
from tests.scripts import load_script

ROOT = Path(__file__).resolve().parents[2]


def _module():
    return load_script("paper_numbers")


def test_identification_page_holds_the_generated_tables():
    text = _module().markdown()
    assert text in (ROOT / "docs" / "identification.md").read_text(encoding="utf-8"), \
        "docs/identification.md is stale: run `PYTHONPATH=. python docs/regenerate_docs.py --only paper-numbers`"


def test_paper_numbers_by_hand():
    m = _module()
    _, p000 = m.paper_000()
    # DC gain of eq. (53) with the printed theta: (b1 + b2) / (1 - a1 - a2 - a3) = 0.0753 / 0.1501
    assert p000["dc_arx"] == pytest.approx(0.0753 / 0.1501, rel=1e-12)
    assert p000["dc_six"] == pytest.approx(0.1178 / 0.1438, rel=1e-9)  # ey / (-ex), rigid water, no damping
    assert np.prod(np.abs(p000["poles"])) == pytest.approx(0.0512, rel=1e-9)  # |a3| = product of the poles
    _, p002 = m.paper_002()
    assert p002["pole"] == pytest.approx(-1.0 / (0.4910 * 1.886), rel=1e-12)
    assert p002["zero"] == pytest.approx(1.0 / (0.0345 * 1.886), rel=1e-12)
    assert p002["initial"] == pytest.approx(-1.4948 * 0.0345 / 0.4910, rel=1e-12)
