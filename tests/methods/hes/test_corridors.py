"""Corridor detection (HES Section 3.2) on hand-built rings: known gaps give known widths and
counts. Rings are built from box worlds with the exact LiDAR, or written by hand."""

import numpy as np
import pytest

from swarmnav.methods.hes.corridors import corridors_toward, detect_gaps, ring_anchors, segment_clear
from swarmnav.sensing import lidar_ring, ray_table
from swarmnav.world.obstacles import Box, Geometry

COS, SIN = ray_table(360)
# Ray spacing at ~10 m is 0.17 m: a throat end point can be missed by up to one spacing.
TOL = 0.25


def ring_at(boxes, p=(0.0, 0.0)):
    geom = Geometry.from_obstacles([Box(lo, hi) for lo, hi in boxes])
    return lidar_ring(geom, np.array([p], dtype=float), 360, 20.0)[0]


def toward(ring, goal, p=(0.0, 0.0), **kw):
    p = np.asarray(p, dtype=float)
    gaps = detect_gaps(ring, p[0], p[1], COS, SIN, 20.0, 0.5)
    return corridors_toward(gaps, p, np.asarray(goal, dtype=float), w_pass=kw.get("w_pass", 2.0),
                            toward_deg=80.0, through=3.0)


def test_parallel_walls_one_corridor_each_way():
    ring = ring_at([((-30, 2.5), (30, 3.5)), ((-30, -3.5), (30, -2.5))])
    gaps = detect_gaps(ring, 0.0, 0.0, COS, SIN, 20.0, 0.5)
    assert len(gaps) == 2  # ahead and behind
    np.testing.assert_allclose(gaps[:, 4], 5.0, atol=1e-9)  # the wall feet are sampled exactly
    (c,) = toward(ring, (40.0, 0.0))
    assert c.width == pytest.approx(5.0)
    np.testing.assert_allclose(c.normal, [1.0, 0.0], atol=1e-9)
    assert c.target[0] > 0


@pytest.mark.parametrize("w1, w2", [(3.0, 6.0), (2.2, 4.0), (5.0, 5.0)])
def test_wall_with_two_gaps_gives_their_widths(w1, w2):
    # A wall at x in [8, 9] across a channel y in [-10, 10], pierced by two gaps centred at y = -4 and y = +4.
    lo1, hi1 = -4 - w1 / 2, -4 + w1 / 2
    lo2, hi2 = 4 - w2 / 2, 4 + w2 / 2
    boxes = [((-20, 10), (40, 11)), ((-20, -11), (40, -10)),
             ((8, -10), (9, lo1)), ((8, hi1), (9, lo2)), ((8, hi2), (9, 10))]
    cands = toward(ring_at(boxes), (30.0, 0.0))
    assert len(cands) == 2
    widths = sorted(c.width for c in cands)
    assert widths[0] == pytest.approx(min(w1, w2), abs=TOL)
    assert widths[1] == pytest.approx(max(w1, w2), abs=TOL)
    for c in cands:
        assert c.mid[0] == pytest.approx(8.0, abs=0.6)  # the throat is at the wall
        assert abs(abs(c.mid[1]) - 4.0) < 0.3
        assert c.normal[0] > 0.9  # exits toward +x


def test_gap_narrower_than_w_pass_is_dropped_and_backward_corridors_ignored():
    boxes = [((-20, 10), (40, 11)), ((-20, -11), (40, -10)),
             ((8, -10), (9, -0.8)), ((8, 0.8), (9, 10))]  # a single 1.6 m slot
    ring = ring_at(boxes)
    assert toward(ring, (30.0, 0.0)) == []
    assert len(toward(ring, (30.0, 0.0), w_pass=1.0)) == 1
    # behind the agent the channel is open; with the goal ahead that opening is not a candidate
    assert all(c.normal[0] > 0 for c in toward(ring, (30.0, 0.0), w_pass=1.0))


def test_concave_corner_is_not_a_corridor():
    ring = ring_at([((5, -10), (6, 10)), ((-10, 5), (6, 6))])  # an L: wall ahead and wall to the left
    cands = toward(ring, (20.0, 20.0))  # the goal lies beyond the corner
    assert cands == []


def test_hand_written_rings():
    assert len(ring_anchors(np.full(360, 20.0), 20.0)) == 0
    assert len(detect_gaps(np.full(360, 20.0), 0.0, 0.0, COS, SIN, 20.0, 0.5)) == 0
    ring = np.full(360, 20.0)
    ring[80:101] = 5.0 / np.sin(np.radians(np.arange(80, 101)))  # a short wall segment above
    ring[260:281] = 5.0 / np.abs(np.sin(np.radians(np.arange(260, 281))))  # and one below
    assert ring_anchors(ring, 20.0).tolist() == [90, 270]
    gaps = detect_gaps(ring, 0.0, 0.0, COS, SIN, 20.0, 0.5)
    assert len(gaps) == 2
    # the closest points across each opening are the segments' ends on the same side
    np.testing.assert_allclose(sorted(gaps[:, 4]), [10.0, 10.0], atol=1e-6)


def test_segment_clear():
    ring = ring_at([((4, -1), (5, 1))])  # a box straight ahead
    assert not segment_clear(ring, 0.0, 0.0, COS, SIN, 0.0, 0.0, 10.0, 0.0, 0.4, 20.0)
    assert segment_clear(ring, 0.0, 0.0, COS, SIN, 0.0, 0.0, 10.0, 3.0 + 10.0, 0.4, 20.0)
    assert segment_clear(ring, 0.0, 0.0, COS, SIN, 0.0, 5.0, 10.0, 5.0, 0.4, 20.0)  # a parallel line above


def _segment_clear_plain(ring, sx, sy, cos_t, sin_t, ax, ay, bx, by, rho, max_range):
    """segment_clear as a per-ray loop with an early exit, plain Python."""
    ex, ey = bx - ax, by - ay
    ee = ex * ex + ey * ey
    for r in range(len(ring)):
        d = ring[r]
        if d >= max_range:
            continue
        qx, qy = sx + d * cos_t[r] - ax, sy + d * sin_t[r] - ay
        s = min(max((qx * ex + qy * ey) / ee, 0.0), 1.0) if ee > 0.0 else 0.0
        dx, dy = qx - s * ex, qy - s * ey
        if dx * dx + dy * dy < rho * rho:
            return False
    return True


def test_segment_clear_tests_every_ray_as_the_plain_loop():
    """The blocked, branch-free ray test answers as the per-ray loop: random rings of 1 to 400
    rays (partly at max range), segments of zero length included, returns near the tube's edge."""
    rng = np.random.default_rng(5)
    answers = set()
    for _ in range(400):
        n = int(rng.integers(1, 400))
        cos_t, sin_t = ray_table(n)
        ring = np.where(rng.random(n) < 0.3, 20.0, rng.uniform(0.5, 20.0, n))
        sx, sy = rng.uniform(-3, 3, 2)
        ax, ay = rng.uniform(-10, 10, 2)
        bx, by = (ax, ay) if rng.random() < 0.1 else tuple(rng.uniform(-10, 10, 2))
        rho = float(rng.choice([0.05, 0.4, 2.0]))
        want = _segment_clear_plain(ring, sx, sy, cos_t, sin_t, ax, ay, bx, by, rho, 20.0)
        assert segment_clear(ring, sx, sy, cos_t, sin_t, ax, ay, bx, by, rho, 20.0) == want
        answers.add(want)
    assert answers == {True, False}
