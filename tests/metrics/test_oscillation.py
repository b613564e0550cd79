"""osc_hf_speed on synthetic trajectories whose answer is known (metrics/oscillation.py)."""

import math

import numpy as np
import pytest

from swarmnav.metrics.oscillation import hf_speed


def _track(velocity, dt: float, seconds: float) -> np.ndarray:
    """Positions (K + 1, 1, 2) [m] integrated exactly from a velocity v(t) = (vx(t), 0)."""
    t = np.arange(int(round(seconds / dt)) + 1) * dt
    x = velocity(t)
    return np.stack([x, np.zeros_like(x)], axis=-1)[:, None, :]


def _sinc(x: float) -> float:
    return math.sin(x) / x


def test_steady_flight_does_not_oscillate():
    dt = 0.01
    t = np.arange(3001) * dt
    p = np.stack([1.2 * t, -0.4 * t], axis=-1)[:, None, :] + np.array([[[3.0, 5.0]]])
    assert hf_speed(p, dt) == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("f", [1.0, 3.0])
def test_a_sinusoid_above_the_cutoff_is_its_rms(f):
    # v = 0.8 + A sin(2 pi f t): position 0.8 t - A / (2 pi f) cos(2 pi f t). A window of exactly one
    # period of the cut-off removes the sinusoid from the average, so the fast part is A sin(...),
    # whose RMS is A / sqrt(2), read through the central difference of the sampled positions
    # (amplitude times sin(w dt) / (w dt), w = 2 pi f: 0.6 % low at 3 Hz and 0.01 s)
    A, dt = 0.2, 0.01
    p = _track(lambda t: 0.8 * t - A / (2 * math.pi * f) * np.cos(2 * math.pi * f * t), dt, 60.0)
    assert hf_speed(p, dt) == pytest.approx(A / math.sqrt(2) * _sinc(2 * math.pi * f * dt), rel=1e-3)


def test_a_slow_turn_is_navigation_not_oscillation():
    # 0.1 Hz, 1 m/s amplitude: the 1 s average keeps 1 - sinc(0.1) = 1.6 % of it outside the mean
    dt = 0.01
    p = _track(lambda t: -1.0 / (2 * math.pi * 0.1) * np.cos(2 * math.pi * 0.1 * t), dt, 60.0)
    got = hf_speed(p, dt)
    assert got < 0.02 / math.sqrt(2) * 1.05
    assert got > 0.0


def test_mean_over_robots_and_the_cutoff_moves_the_split():
    # robot 0 shakes at 3 Hz, robot 1 flies straight: the mean square halves, the RMS is A / 2
    A, dt = 0.3, 0.02
    shake = _track(lambda t: 0.5 * t - A / (2 * math.pi * 3.0) * np.cos(2 * math.pi * 3.0 * t), dt, 40.0)
    steady = _track(lambda t: 0.5 * t, dt, 40.0)
    p = np.concatenate([shake, steady], axis=1)
    assert hf_speed(p, dt) == pytest.approx(A / 2 * _sinc(2 * math.pi * 3.0 * dt), rel=1e-3)
    # a cut-off of 5 Hz averages over 0.2 s, which passes sinc(3 Hz x 0.2 s) = 0.50 of the 3 Hz
    # shaking into the slow part: half of it is left as oscillation (5 %: the discrete window)
    ratio = hf_speed(p, dt, cutoff_hz=5.0) / hf_speed(p, dt)
    assert ratio == pytest.approx(1 - math.sin(0.6 * math.pi) / (0.6 * math.pi), rel=0.05)


def test_too_short_a_run_has_no_value_and_bad_steps_are_refused():
    assert math.isnan(hf_speed(np.zeros((50, 3, 2)), 0.01))
    with pytest.raises(ValueError):
        hf_speed(np.zeros((500, 3, 2)), 0.0)
