"""The shared planning layer: replanning schedule, sampled references, the tracking law, and
the messages counted for ``comm_mbps``."""

from __future__ import annotations

import numpy as np
import pytest

import swarmnav
from swarmnav.methods import registry
from swarmnav.planning.bspline import SplinePlan, boundary_points
from swarmnav.planning.messages import POSITION_BYTES, CommLog, TrajectoryBoard, sample_broadcasts, trajectory_bytes
from swarmnav.planning.schedule import ReplanSchedule
from swarmnav.planning.tracker import References, track


def test_schedule_replans_every_period_from_the_last_replan():
    s = ReplanSchedule(0.2, 0.01)
    assert s.every == 20
    due = []
    for k in range(60):
        if s.due(k):
            due.append(k)
            s.done(k)
    assert due == [0, 20, 40]
    late = ReplanSchedule(0.2, 0.01)
    late.done(5)
    assert not late.due(24) and late.due(25)


def _line(tau):
    """A plan at 2 m/s along x from the origin."""
    q = np.stack([2.0 * tau, np.zeros_like(tau)], axis=1)
    return q, np.tile([2.0, 0.0], (len(tau), 1)), np.zeros((len(tau), 2))


def test_references_sample_each_plan_on_the_control_clock_and_hold_the_last_sample():
    refs = References()
    assert refs.empty
    refs.load([_line, _line], step=100, length=10, dt=0.1, dim=2)
    q, v, _ = refs.at(103)
    np.testing.assert_allclose(q[:, 0], [0.6, 0.6])
    q, _, _ = refs.at(103, delay=np.array([0, 2]))
    np.testing.assert_allclose(q[:, 0], [0.6, 0.2])
    q, _, _ = refs.at(500)  # past the end: the last sample
    np.testing.assert_allclose(q[:, 0], [1.8, 1.8])


def test_tracking_law_is_eq13_and_vanishes_on_the_reference():
    rng = np.random.default_rng(1)
    x, v, q, w, a = (rng.normal(size=(5, 3)) for _ in range(5))
    np.testing.assert_allclose(track(x, v, q, w, a, 5.0, 3.5), 5.0 * (q - x) + 3.5 * (w - v) + a)
    np.testing.assert_allclose(track(q, w, q, w, a, 5.0, 3.5), a)
    f = rng.normal(size=(5, 3))
    np.testing.assert_allclose(track(x, v, q, w, a, 5.0, 3.5, feedforward=f), f + track(x, v, q, w, a, 5.0, 3.5))


def test_spline_plan_sample_reproduces_its_boundary_state():
    q0, v0, a0 = np.array([1.0, 2.0]), np.array([0.5, -0.25]), np.array([0.1, 0.0])
    ctrl = np.vstack([boundary_points(q0, v0, a0, 0.5), boundary_points(q0 + 3.0, v0, a0, 0.5)])
    q, v, a = SplinePlan(ctrl, 0.5, 0).sample(np.array([0.0]))
    np.testing.assert_allclose(q[0], q0)
    np.testing.assert_allclose(v[0], v0)
    np.testing.assert_allclose(a[0], a0, atol=1e-12)


def test_comm_log_counts_periodic_broadcasts_and_their_load():
    log = CommLog()
    for k in range(300):
        log.periodic(k, 0.01, 10.0, 15, POSITION_BYTES)
    s = log.summary(3.0)
    assert s["comm_messages"] == 15 * 30
    assert s["comm_bytes"] == 15 * 30 * 64
    assert s["comm_mbps"] == pytest.approx(15 * 10 * 64 * 8 / 1e6)  # the paper's 0.075 Mbit/s class


def test_trajectory_board_counts_each_publication_and_samples_on_the_run_clock():
    log = CommLog()
    board = TrajectoryBoard(3, log)
    board.publish(1, _line, t_start=2.0, duration=1.0, n_points=10)
    assert log.messages == 1 and log.bytes == trajectory_bytes(10) == 56 + 240
    got = board.sample(np.array([0, 1]), np.array([1.0, 2.5, 9.0]), 2)
    assert np.isnan(got[0]).all()  # robot 0 has published nothing
    np.testing.assert_allclose(got[1, :, 0], [0.0, 1.0, 2.0])  # clamped before the start and after the end


def test_a_broadcast_record_is_the_board_s_plan_read_on_the_same_clock():
    board = TrajectoryBoard(3, CommLog())
    board.publish(1, _line, t_start=2.0, duration=1.0, n_points=10, data="extra")
    rec = board.records[1]
    assert board.records[0] is None and rec.data == "extra"
    with pytest.raises(AttributeError):  # immutable: what travels is what was sent
        rec.start = 0.0
    times = np.array([1.0, 2.5, 9.0])
    got = sample_broadcasts([None, rec], times, 2)
    np.testing.assert_array_equal(got, board.sample(np.array([0, 1]), times, 2))
    board.publish(1, _line, t_start=5.0, duration=1.0, n_points=10)  # a newer plan replaces the record...
    np.testing.assert_array_equal(sample_broadcasts([rec], times, 2)[0], got[1])  # ...and leaves the old one as sent


def test_sph_comm_mbps_is_counted_from_its_broadcasts():
    m = registry.make("sph")
    res = swarmnav.run(m, "random_forest:density=0.15,seed=1", seed=1, steps=200)
    n = res.positions.shape[1]
    assert res.metrics["comm_messages"] == n * 20
    assert res.metrics["comm_mbps"] == pytest.approx(n * 10 * 64 * 8 / 1e6)
    quiet = swarmnav.run(registry.make("sph", broadcast_hz=0.0), "random_forest:density=0.15,seed=1", seed=1, steps=200)
    assert quiet.metrics["comm_mbps"] == 0.0
    np.testing.assert_array_equal(quiet.positions, res.positions)  # counting messages changes no flight
