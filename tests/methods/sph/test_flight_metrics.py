"""Table II metrics (swarmnav.metrics.flight) on trajectories with known answers."""

import numpy as np
import pytest

from swarmnav.metrics.flight import FlightParams, flight_metrics

DT = 0.1
GOAL = np.array([10.0, 0.0])


def _line(n=2, speed=1.0, steps=150, y_gap=2.0):
    t = DT * np.arange(steps + 1)
    x = np.minimum(speed * t, 10.0)
    P = np.stack([np.column_stack([x, np.full_like(x, y_gap * a)]) for a in range(n)], axis=1)
    V = np.gradient(P, DT, axis=0)
    return P, V, np.full(P.shape[:2], np.inf)


def test_straight_flight_time_distance_velocity():
    P, V, C = _line(n=1)
    m = flight_metrics(P, V, C, GOAL, DT, FlightParams(r_goal=3.0))
    assert m["flight_time"] == pytest.approx(7.0)  # within 3 m of the goal at x = 7 m
    assert m["flight_distance"] == pytest.approx(7.0)
    assert m["avg_velocity"] == pytest.approx(1.0)
    assert m["sph_success"] == 1.0 and m["min_robot_obstacle_distance"] == np.inf


def test_jerk_energy_of_constant_jerk():
    c = 0.6  # q = c t^3 / 6: jerk c, energy c^2 T
    t = DT * np.arange(101)
    P = np.column_stack([c * t**3 / 6, np.zeros_like(t)])[:, None, :]
    m = flight_metrics(P, np.zeros_like(P), np.full((101, 1), np.inf), np.array([1e3, 0.0]), DT)
    assert m["jerk_energy"] == pytest.approx(c**2 * DT * 98)  # 98 third differences in 100 steps
    P0, V0, C0 = _line(n=1)
    assert flight_metrics(P0[:60], V0[:60], C0[:60], GOAL, DT)["jerk_energy"] == pytest.approx(0.0, abs=1e-9)


def test_bandwidth_is_ten_hz_position_broadcasts():
    P, V, C = _line(n=15, y_gap=0.5)
    assert flight_metrics(P, V, C, GOAL, DT)["comm_mbps"] == pytest.approx(15 * 10 * 64 * 8 / 1e6)  # 0.0768


def test_contact_or_missed_goal_is_failure():
    P, V, C = _line(n=2, y_gap=0.35)  # two bodies of 0.2 m radius 0.35 m apart: contact
    m = flight_metrics(P, V, C, GOAL, DT)
    assert m["min_inter_robot_distance"] == pytest.approx(0.35) and m["sph_success"] == 0.0
    P, V, C = _line(n=2, y_gap=1.0, steps=40)  # stopped short of the goal region
    m = flight_metrics(P, V, C, GOAL, DT)
    assert m["sph_success"] == 0.0 and m["flight_time"] == pytest.approx(4.0)  # censored at the horizon
    P, V, C = _line(n=1)
    C[50] = 0.1  # grazed an obstacle
    assert flight_metrics(P, V, C, GOAL, DT)["sph_success"] == 0.0


def test_coordination_time_is_first_coherent_motion():
    P, V, C = _line(n=3, y_gap=1.0)
    V[:5] = 0.0  # at rest for 0.5 s
    assert flight_metrics(P, V, C, GOAL, DT)["coordination_time"] == pytest.approx(0.5)


def test_coordination_time_ignores_weaving_and_scales_with_the_ramp():
    # Two robots speed up along x over 2 s to 1 m/s, each weaving sideways at 0.6 m/s in
    # opposite phase (as robots passing trees on either side): the polarisation stays at
    # 1 / sqrt(1 + 0.36) = 0.86 < 0.9 through the whole flight, but the swarm's centre moves
    # coherently: it reaches 0.8 x its median speed (1 m/s) at t = 1.6 s.
    steps = 200
    t = DT * np.arange(steps + 1)
    vx = np.minimum(t / 2.0, 1.0)
    V = np.zeros((steps + 1, 2, 2))
    V[:, :, 0] = vx[:, None]
    V[:, 0, 1], V[:, 1, 1] = 0.6 * vx, -0.6 * vx
    P = np.cumsum(V, axis=0) * DT + np.array([[0.0, 1.0], [0.0, -1.0]])
    C = np.full(P.shape[:2], np.inf)
    far = np.array([1e3, 0.0])  # never arrives: the median is over the whole run
    assert flight_metrics(P, V, C, far, DT)["coordination_time"] == pytest.approx(1.6)
    # the same flight at half the speed: the same time (relative to the run's own cruise)
    assert flight_metrics(P / 2, V / 2, C, far, DT)["coordination_time"] == pytest.approx(1.6)


def test_swarm_goal_disc_grows_with_the_square_root_of_the_swarm():
    for n, r in ((1, 3.0), (15, 3.0), (30, 3.0 * np.sqrt(2)), (60, 6.0), (100, 3.0 * np.sqrt(100 / 15))):
        P, V, C = _line(n=n, y_gap=0.5)
        assert flight_metrics(P, V, C, GOAL, DT)["sph_swarm_goal_radius"] == pytest.approx(r)


def test_swarm_success_asks_for_arrival_not_presence_at_the_end():
    P, V, C = _line(n=1, steps=200)
    P[150:, 0, 1] = np.linspace(0.0, 8.0, 51)  # at the goal at 15 s, then drifts 8 m sideways
    m = flight_metrics(P, V, C, GOAL, DT)
    assert m["sph_success"] == 0.0 and m["sph_arrived_fraction"] == 0.0  # not inside at the end
    assert m["sph_swarm_success"] == 1.0 and m["sph_swarm_arrived_fraction"] == 1.0  # but it arrived


def test_swarm_of_sixty_inside_its_disc_succeeds_where_the_three_metre_test_fails():
    n = 60
    ang = np.linspace(0, 2 * np.pi, n, endpoint=False)
    ring = GOAL + 5.0 * np.column_stack([np.cos(ang), np.sin(ang)])  # 60 robots 0.52 m apart, 5 m out
    P = np.repeat(ring[None], 11, axis=0)
    V, C = np.zeros_like(P), np.full(P.shape[:2], np.inf)
    m = flight_metrics(P, V, C, GOAL, DT)
    assert m["sph_swarm_goal_radius"] == pytest.approx(6.0)
    assert m["sph_swarm_success"] == 1.0 and m["sph_success"] == 0.0
    far = P.copy()
    far[:, 0] += np.array([2.0, 0.0])  # one robot 7 m out never arrives
    assert flight_metrics(far, V, C, GOAL, DT)["sph_swarm_success"] == 0.0


def test_swarm_success_fails_on_contact_after_arrival_and_on_a_crash():
    P, V, C = _line(n=2, y_gap=1.0)
    P[-1, 1] = P[-1, 0] + np.array([0.3, 0.0])  # arrived, then 0.3 m from the other robot
    assert flight_metrics(P, V, C, GOAL, DT)["sph_swarm_success"] == 0.0
    P, V, C = _line(n=2, y_gap=1.0)
    assert flight_metrics(P, V, C, GOAL, DT)["sph_swarm_success"] == 1.0
    assert flight_metrics(P, V, C, GOAL, DT, crashed=np.array([False, True]))["sph_swarm_success"] == 0.0
