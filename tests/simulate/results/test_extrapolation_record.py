"""The extrapolation record computed in one compiled pass (:func:`simulate.loop.domain._record_numbers`) against the
same figures by numpy, written out here the way the record defines them."""

import numpy as np
import pytest

from simulate.loop.domain import TrustedDomain, extrapolation_record


def by_numpy(domain, time_s, n11, opening, stroke, figure_times):
    masks = domain.masks(n11, opening, stroke)
    dt = np.diff(time_s)
    out = {}
    for kind, mask in masks.items():
        if not mask.any():
            out[kind] = {"fraction_of_time": 0.0}
            continue
        out[kind] = {"fraction_of_time": dt[mask[1:]].sum() / (time_s[-1] - time_s[0]),
                     "first_time_s": time_s[np.argmax(mask)], "n11_min": np.min(n11[mask]),
                     "n11_max": np.max(n11[mask]), "opening_min": np.min(opening[mask]),
                     "opening_max": np.max(opening[mask]), "stroke_max": np.max(stroke[mask])}
    figures = {}
    for name, t in figure_times.items():
        until = time_s[1:] <= t
        span = dt[until].sum()
        figures[name] = {kind: (dt[until & mask[1:]].sum() / span if span > 0 else 0.0) for kind, mask in masks.items()}
    edges = np.diff(np.concatenate(([0], np.any(list(masks.values()), axis=0).astype(np.int8), [0])))
    intervals = [[time_s[s], time_s[e]] for s, e in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1)]
    return out, figures, intervals


@pytest.fixture
def trajectory():
    rng = np.random.default_rng(7)
    time_s = np.cumsum(rng.uniform(0.005, 0.02, 2000))
    n11 = 70.0 + 40.0 * np.sin(time_s) + rng.normal(0.0, 5.0, time_s.size)  # in and out of the range many times
    opening = np.clip(20.0 + 15.0 * np.cos(0.7 * time_s), 0.0, None)
    stroke = opening / 30.0  # above 1 now and then
    return time_s, n11, opening, stroke


def test_the_record_is_numpy_s_to_rounding(trajectory):
    time_s, n11, opening, stroke = trajectory
    hull = np.array([[40.0, 0.0], [110.0, 0.0], [110.0, 40.0], [60.0, 30.0], [40.0, 20.0]])
    domain = TrustedDomain((45.0, 100.0), (1.0, 32.0), hull, "test")
    figures = {"early": time_s[100], "late": time_s[-50], "before": time_s[0] - 1.0}
    record = extrapolation_record(domain, time_s, n11, opening, stroke, figure_times=figures)
    kinds, shares, intervals = by_numpy(domain, time_s, n11, opening, stroke, figures)
    assert len(intervals) > 20  # the check covers many runs outside
    # 1e-12 relative: the pass sums the steps in order, numpy pairwise (rounding of ~2000 terms, ~1e-14)
    for kind, expected in kinds.items():
        assert list(record[kind]) == list(expected)
        for key, value in expected.items():
            assert record[kind][key] == pytest.approx(value, rel=1e-12, abs=0.0), (kind, key)
    for name, expected in shares.items():
        for kind, value in expected.items():
            assert record["figures"][name][kind] == pytest.approx(value, rel=1e-12, abs=0.0), (name, kind)
    assert record["intervals_s"] == intervals  # times read from the series: exact


def test_a_nan_makes_the_extremes_nan_as_numpy_does(trajectory):
    time_s, n11, opening, stroke = trajectory
    n11, opening = n11.copy(), opening.copy()
    n11[500], opening[500] = np.nan, 50.0  # outside by its opening, with no N11
    domain = TrustedDomain((45.0, 100.0), (1.0, 32.0))
    record = extrapolation_record(domain, time_s, n11, opening, stroke)
    assert np.isnan(record["training_range"]["n11_min"]) and np.isnan(record["training_range"]["n11_max"])
    assert np.isnan(np.min(n11[domain.masks(n11, opening, stroke)["training_range"]]))  # numpy's own answer
    # the failing case beside it: without the NaN the extremes are numbers
    clean = extrapolation_record(domain, time_s, np.nan_to_num(n11, nan=70.0), opening, stroke)
    assert np.isfinite(clean["training_range"]["n11_min"])


def test_each_warning_says_what_to_do():
    from simulate.loop.domain import extrapolation_warnings

    hull = np.array([[60.0, 10.0], [90.0, 10.0], [90.0, 30.0], [60.0, 30.0]])
    domain = TrustedDomain((40.0, 100.0), (0.0, 32.0), hull, "flow.csv")
    time_s = np.linspace(0.0, 10.0, 11)
    n11 = np.linspace(70.0, 110.0, 11)  # leaves the hull at 90, the training range at 100
    opening = np.full(11, 20.0)
    stroke = np.linspace(0.9, 1.1, 11)  # beyond full stroke from t = 6 s
    lines = extrapolation_warnings(extrapolation_record(domain, time_s, n11, opening, stroke))
    assert [line.split(" for ")[0] for line in lines] == ["outside the nets' training range",
                                                          "outside the digitized region of the chart",
                                                          "beyond full guide-vane stroke"]
    assert lines[0].endswith("the nets extrapolate there; extend the chart that far (hillsim extend) and retrain")
    assert lines[1].endswith("summary.json (extrapolation.figures) gives each figure's share of it, and "
                             "--uncertainty its band")
    assert lines[2].endswith("set governor.stroke_max = 1 unless the chart goes beyond")
    # inside everywhere: nothing to say
    assert extrapolation_warnings(extrapolation_record(domain, time_s, np.full(11, 70.0), opening,
                                                       np.full(11, 0.5))) == []
