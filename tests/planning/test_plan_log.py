"""The record of committed plans (planning/plan_log.py): samples every 0.1 s with the plan's
end, a horizon that bounds a plan stretched without limit, flat arrays that rebuild each plan,
and a non-finite sample that ends a plan's record instead of reaching the run's result."""

from __future__ import annotations

import numpy as np
import pytest

from swarmnav.planning.plan_log import HORIZON, SAMPLE_SPACING, PlanLog, sample_rows, sample_times


@pytest.mark.parametrize("duration, want", [(0.0, [0.0]), (0.05, [0.0, 0.05]), (0.3, [0.0, 0.1, 0.2, 0.3]),
                                            (0.25, [0.0, 0.1, 0.2, 0.25])])
def test_sample_times_every_spacing_and_the_end(duration, want):
    np.testing.assert_allclose(sample_times(duration), want, atol=1e-12)


def test_a_plan_stretched_without_bound_is_recorded_over_the_horizon():
    assert sample_times(np.nan).tolist() == [0.0]
    for d in (HORIZON, 1e6, 1e115, np.inf):
        t = sample_times(d)
        assert len(t) == round(HORIZON / SAMPLE_SPACING) + 1 and t[-1] == pytest.approx(HORIZON)
    rows = sample_rows(10**6, 0.02)
    assert rows[-1] == round(HORIZON / 0.02) and np.all(np.diff(rows) == 5)


@pytest.mark.parametrize("length, want", [(1, [0]), (2, [0, 1]), (6, [0, 5]), (12, [0, 5, 10, 11])])
def test_sample_rows_every_tenth_of_a_second_of_a_50_hz_reference_and_its_last(length, want):
    assert sample_rows(length, 0.02).tolist() == want


def test_the_flat_arrays_rebuild_each_plan_in_commit_order():
    log = PlanLog(3)
    plans = [(0, 2, np.arange(3.0), np.ones((3, 3))), (0, 0, np.arange(1.0), np.zeros((1, 3))),
             (7, 2, 0.14 + np.arange(2.0), np.full((2, 3), 5.0))]
    for p in plans:
        log.add(*p)
    a = log.arrays()
    assert a["step"].tolist() == [0, 0, 7] and a["robot"].tolist() == [2, 0, 2] and a["offsets"].tolist() == [0, 3, 4, 6]
    assert a["points"].dtype == np.float32 and a["points"].shape == (6, 3) and a["times"].shape == (6,)
    for j, (_, _, t, x) in enumerate(plans):
        o0, o1 = a["offsets"][j], a["offsets"][j + 1]
        np.testing.assert_array_equal(a["points"][o0:o1], x)
        np.testing.assert_allclose(a["times"][o0:o1], t, rtol=1e-7)
    empty = PlanLog(2).arrays()
    assert empty["offsets"].tolist() == [0] and empty["points"].shape == (0, 2)


def test_a_non_finite_sample_ends_the_plans_record():
    log = PlanLog(2)
    x = np.array([[0.0, 0.0], [1.0, 0.0], [np.nan, 0.0], [3.0, 0.0]])
    log.add(0, 0, np.arange(4.0), x)
    log.add(0, 1, np.arange(4.0), x[::-1])  # its second sample is not finite: its first is kept
    log.add(0, 2, np.arange(2.0), np.array([[np.inf, 0.0], [1.0, 1.0]]))  # no finite start: not recorded
    a = log.arrays()
    assert a["robot"].tolist() == [0, 1] and a["offsets"].tolist() == [0, 2, 3]
    assert np.isfinite(a["points"]).all()
    with pytest.raises(ValueError, match="as many times as points"):
        log.add(1, 0, np.arange(2.0), x)
