"""Statistics over seeds: NumPy's numbers for finite data; defined and silent with inf."""

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmnav.experiments import stats
from swarmnav.experiments.runner import summarize

finite = st.lists(st.floats(-1e6, 1e6, allow_nan=False), min_size=1, max_size=30)


@settings(max_examples=200, deadline=None)
@given(vals=finite, q=st.sampled_from([0, 10, 25, 50, 75, 90, 100]))
def test_finite_data_matches_numpy(vals, q):
    v = np.array(vals)
    assert stats.mean(v) == pytest.approx(np.mean(v), rel=1e-12, abs=1e-9)
    assert stats.std(v) == pytest.approx(np.std(v), rel=1e-9, abs=1e-9)
    assert stats.percentile(v, q) == pytest.approx(np.percentile(v, q), rel=1e-12, abs=1e-9)


def test_infinite_values_give_defined_numbers_without_warnings():
    v = np.array([3.0, 1.0, np.inf, 2.0, np.inf])  # sorted: 1 2 3 inf inf
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert stats.mean(v) == np.inf
        assert np.isnan(stats.std(v))
        assert stats.percentile(v, 25) == 2.0  # exactly on an order statistic
        assert stats.percentile(v, 50) == 3.0
        assert stats.percentile(v, 60) == np.inf  # between 3 and inf
        assert stats.percentile(v, 75) == np.inf  # between inf and inf
        assert np.isnan(stats.mean(np.array([])))
        lows = np.array([-np.inf, 1.0, 2.0])
        assert stats.percentile(lows, 25) == -np.inf and stats.percentile(lows, 75) == 1.5
        assert np.isnan(stats.percentile(np.array([-np.inf, np.inf]), 50))


def test_summary_of_runs_that_never_converge_is_quiet():
    rows = [{"variant": "v", "status": "done", "k_con": k} for k in (5.0, np.inf, 7.0, np.inf)]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        (s,) = summarize(rows, [{"name": "v", "columns": {"variant": "v"}}])
    assert s["k_con_mean"] == np.inf and np.isnan(s["k_con_std"])
    assert (s["k_con_p25"], s["k_con_p50"], s["k_con_p75"]) == (6.5, np.inf, np.inf)


def test_report_figures_draw_variants_with_infinite_runs_without_warnings():
    from swarmnav.experiments.report import _cell, figures

    t = {"title": "t", "metrics": ["k_con"], "variants": [
        {"name": "some never converge", "values": {"k_con": np.array([1.0, np.inf])}},
        {"name": "all converge", "values": {"k_con": np.array([2.0, 3.0])}},
        {"name": "none converges", "values": {"k_con": np.array([np.inf, np.inf])}}]}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pngs = dict(figures(t))
    assert set(pngs) == {"bars.png", "boxes.png"} and all(b[:4] == b"\x89PNG" for b in pngs.values())
    assert _cell(np.array([1.0, np.inf])) == "inf"  # no undefined ± spread
    assert _cell(np.array([2.0, 3.0])) == "2.500 ± 0.500"
