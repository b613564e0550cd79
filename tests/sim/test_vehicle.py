"""The vehicle of a run (swarmnav/dynamics/vehicle.py, docs/vehicle.md): the point vehicle changes
nothing; every method flies a quadrotor, finite and measured; wind and downwash need one; bad
input is one line; a run's key holds the vehicle as resolved."""

from dataclasses import dataclass

import numpy as np
import pytest

import swarmnav
from _helpers.cli import run_cli
from swarmnav.errors import ConfigError
from swarmnav.methods import registry
from swarmnav.methods.base import Observation
from swarmnav.sim.referee import Referee

QUAD = {"vehicle": "quadrotor"}


@dataclass(frozen=True, slots=True)
class _HoverParams:
    dt: float = 0.05


class _Hover:
    """A user's method: every agent asks for no acceleration (a saturated double integrator)."""

    name = "hover"
    dims = (2, 3)
    networked = True

    def __init__(self):
        from swarmnav.dynamics import SaturatedDoubleIntegrator
        self.dt = 0.05
        self.params = _HoverParams()
        self.dynamics = SaturatedDoubleIntegrator(1.0, 1.5)

    def reset(self, scenario, pos, vel, rng):
        self.n, self.d = pos.shape

    def act(self, obs: Observation, rng):
        return np.zeros((self.n, self.d)), {}

    def summary(self):
        return {}


def test_the_point_vehicle_named_is_the_run_without_one():
    a = swarmnav.run("vasarhelyi", "default_corridor", seed=2, steps=60)
    b = swarmnav.run("vasarhelyi", "default_corridor", seed=2, steps=60, vehicle="point")
    assert np.array_equal(a.positions, b.positions) and np.array_equal(a.velocities, b.velocities)
    assert "vehicle" not in b.config and not any(k.startswith("vehicle_") for k in b.metrics)


def test_a_quadrotor_at_rest_hovers_where_it_started():
    r = swarmnav.run(_Hover(), "default_corridor", seed=1, steps=100, **QUAD)
    drift = np.linalg.norm(r.positions[-1] - r.positions[0], axis=1)
    assert drift.max() < 1e-6  # 5 s of hover at the hover rotor speed: nothing moves
    assert r.metrics["vehicle_tilt_max"] < 1e-6 and r.metrics["vehicle_flips"] == 0.0
    assert r.config["vehicle"]["model"] == "quadrotor" and r.config["vehicle"]["airframe"] == "crazyflie"


def _scenes(method):
    spec = registry.spec(method)
    if not spec.navigation:  # the Vicsek family flies its periodic box
        return ["periodic_box:n=20,seed=1"]
    dims = registry.make(method).dims
    # MADER's first 3-D plan costs ~40 s here; the vehicle layer does not depend on the method, and
    # MADER flies the 2-D scene (its 3-D flight is in the conformance tests)
    return ["default_corridor"] + (["sph_cluttered_3d"] if 3 in dims and method != "mader" else [])


@pytest.mark.parametrize("method, scene", [(m, s) for m in registry.names() for s in _scenes(m)])
def test_every_method_flies_a_quadrotor(method, scene):
    steps = max(20, int(round(1.0 / registry.make(method).dt)))
    r = swarmnav.run(method, scene, seed=3, steps=steps, **QUAD)
    assert np.isfinite(r.positions).all() and np.isfinite(r.velocities).all()
    m = r.metrics
    for key in ("vehicle_tilt_max", "vehicle_thrust_sat_fraction", "vehicle_track_err_mean",
                "vehicle_track_err_max", "vehicle_energy_mean", "vehicle_flips"):
        assert np.isfinite(m[key]), key
    assert 0.0 <= m["vehicle_thrust_sat_fraction"] <= 1.0
    assert 0.0 <= m["vehicle_track_err_mean"] <= m["vehicle_track_err_max"]
    assert m["vehicle_energy_mean"] > 0.0  # the rotors hold the vehicle up: they spend energy


def test_a_quadrotor_lags_the_point_model_and_the_lag_is_measured():
    point = swarmnav.run("vasarhelyi", "default_corridor", seed=4, steps=200)
    quad = swarmnav.run("vasarhelyi", "default_corridor", seed=4, steps=200, **QUAD)
    assert not np.array_equal(point.positions, quad.positions)
    assert quad.metrics["vehicle_track_err_max"] > 0.0 and quad.metrics["vehicle_tilt_max"] > 0.0
    # the same seed flies the same quadrotors
    again = swarmnav.run("vasarhelyi", "default_corridor", seed=4, steps=200, **QUAD)
    assert np.array_equal(quad.positions, again.positions)


def test_wind_pushes_a_quadrotor_that_no_one_steers():
    calm = swarmnav.run(_Hover(), "default_corridor", seed=1, steps=100, **QUAD)
    windy = swarmnav.run(_Hover(), "default_corridor", seed=1, steps=100, **QUAD,
                         **{"wind.speed": 6.0, "wind.direction": 0.0})
    push = windy.positions[-1] - calm.positions[-1]
    assert np.all(push[:, 0] > 0.01)  # downwind, along +x: the drag of the wind outruns the velocity loop
    assert windy.config["wind"]["speed"] == 6.0


@pytest.mark.parametrize("options, words", [
    ({"vehicle": "boat"}, "vehicle"),
    ({"vehicle": "quadrotor", "vehicle.airframe": "blimp"}, "blimp"),
    ({"vehicle": "quadrotor", "vehicle.mass": -1.0}, "mass"),
    ({"vehicle": "quadrotor", "vehicle.mass": 5.0}, "hover"),  # a Crazyflie's rotors cannot lift 5 kg
    ({"vehicle": "quadrotor", "vehicle.inner_hz": 5.0}, "inner_hz"),  # slower than the method's 20 Hz
    ({"wind.speed": 3.0}, "vehicle=quadrotor"),
    ({"downwash": True}, "vehicle=quadrotor"),
    ({"vehicle.airframe": "hummingbird"}, "vehicle=quadrotor"),
    ({"vehicle": "quadrotor", "wind.speed": -1.0}, "speed"),
    ({"vehicle": "quadrotor", "vehicle.yaw": "spin"}, "yaw"),
    ({"vehicle": "quadrotor", "vehicle.yaw": "velocity", "vehicle.yaw_rate_max": 0.0}, "yaw_rate_max"),
    ({"vehicle": "quadrotor", "vehicle.yaw_rate_max": 90.0}, "vehicle.yaw=velocity"),  # no effect with yaw held
])
def test_bad_vehicle_options_are_one_line(options, words):
    with pytest.raises(ConfigError) as e:
        swarmnav.run(_Hover(), "default_corridor", seed=1, steps=5, **options)
    assert words in str(e.value) and "\n" not in str(e.value)


def test_bad_vehicle_option_on_the_cli_is_exit_2(tmp_path):
    r = run_cli("run", "--method", "apf", "--scenario", "default_corridor", "--steps", "5",
                "--out", str(tmp_path / "r"), "--set", "wind.speed=6")
    assert r.returncode == 2 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_the_cli_flies_a_quadrotor_in_wind(tmp_path):
    r = run_cli("run", "--method", "apf", "--scenario", "default_corridor", "--steps", "20",
                "--out", str(tmp_path / "r"), "--set", "vehicle=quadrotor", "--set", "wind.speed=3")
    assert r.returncode == 0, r.stderr
    import json
    cfg = json.loads((tmp_path / "r" / "config.json").read_text())
    assert cfg["vehicle"]["model"] == "quadrotor" and cfg["wind"]["speed"] == 3.0


def test_the_referee_crashes_an_agent_for_a_stated_reason():
    ref = Referee(3, 0.2)
    pos = np.array([[0.0, 0.0], [5.0, 0.0], [10.0, 0.0]])
    ev = ref.fail(7, np.array([False, True, False]), pos, "flipped")
    assert ev == [{"step": 7, "action": "crash", "agent": 1, "source": "referee", "reason": "flipped"}]
    assert ref.crashed.tolist() == [False, True, False]
    assert ref.fail(8, np.array([False, True, False]), pos, "flipped") == []  # crashed once
    moved, vel = pos + 1.0, np.ones((3, 2))
    ref.hold(moved, vel)
    assert np.array_equal(moved[1], pos[1]) and np.array_equal(vel[1], [0.0, 0.0])


class _Push(_Hover):
    """Every agent asks for 1 m/s^2 along +x, and the method ends the run after ``stop`` steps."""

    name = "push"

    def __init__(self, stop):
        super().__init__()
        self.stop = stop

    def act(self, obs: Observation, rng):
        a = np.zeros((self.n, self.d))
        a[:, 0] = 1.0
        return a, {"done": obs.step + 1 >= self.stop}


def test_a_quadrotor_run_records_its_thrust_axes_and_they_round_trip(tmp_path):
    r = swarmnav.run(_Push(16), "default_corridor", seed=1, steps=100, **QUAD)  # 0.8 s, below v_max
    K1, N, d = r.positions.shape
    assert (K1, d) == (17, 2)  # the method ended the run: the axes are cut with the positions
    A = r.thrust_axis
    assert A.shape == (K1, N, 3) and A.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(A, axis=2), 1.0, atol=1e-6)
    assert np.array_equal(A[0], np.tile([0.0, 0.0, 1.0], (N, 1)))  # level at the start
    # accelerating at a = 1 m/s^2 along +x, each vehicle leans its thrust forward by atan(a / g),
    # 5.8 deg (a little more against its body drag), once its attitude has caught up (~0.3 s)
    lean = np.degrees(np.arctan2(A[-5:, :, 0], A[-5:, :, 2]))
    assert np.all((lean > 5.3) & (lean < 7.0)), lean
    assert np.abs(A[:, :, 1]).max() < 1e-3  # no sideways lean
    assert np.degrees(np.arccos(A[..., 2].min())) <= r.metrics["vehicle_tilt_max"] + 1e-3
    r.save(tmp_path)
    with np.load(tmp_path / "trajectory.npz") as z:
        assert z["thrust_axis"].dtype == np.float32
    back = swarmnav.RunResult.load(tmp_path)
    assert np.array_equal(back.thrust_axis, A)


def test_a_point_mass_run_has_no_thrust_axis(tmp_path):
    r = swarmnav.run(_Push(5), "default_corridor", seed=1, steps=10)
    assert r.thrust_axis is None
    r.save(tmp_path)
    with np.load(tmp_path / "trajectory.npz") as z:
        assert "thrust_axis" not in z.files
    assert swarmnav.RunResult.load(tmp_path).thrust_axis is None


def test_a_damaged_thrust_axis_is_one_line(tmp_path):
    r = swarmnav.run(_Push(5), "default_corridor", seed=1, steps=10, **QUAD)
    r.thrust_axis = r.thrust_axis[:-1]
    r.save(tmp_path)
    with pytest.raises(swarmnav.SwarmnavError, match="thrust_axis"):
        swarmnav.RunResult.load(tmp_path)


class _Recorded:
    """A registered method whose commands are kept, step by step (for a plain reference)."""

    def __init__(self, inner):
        self.inner = inner
        self.cmds = []

    def __getattr__(self, key):
        return getattr(self.inner, key)

    def act(self, obs, rng):
        cmd, info = self.inner.act(obs, rng)
        self.cmds.append(np.array(cmd, dtype=float))
        return cmd, info


def test_the_tracking_error_counts_only_the_robots_still_flying():
    m = _Recorded(registry.make("apf"))
    r = swarmnav.run(m, "default_corridor", seed=1, steps=120, **QUAD)
    crash = {e["agent"]: e["step"] for e in r.events if e.get("action") == "crash"}
    assert 0 < len(crash) < r.positions.shape[1] and r.metrics["vehicle_flips"] == 0.0  # some, not all, crashed
    # plain reference: the step from recorded state k to k + 1 against the point model's step from
    # state k under the same command, over the robots not crashed at state k
    P, V, dt = r.positions, r.velocities, m.dt
    crashed_at = np.array([crash.get(i, np.inf) for i in range(P.shape[1])])
    means, worst, every = [], 0.0, []
    for k, cmd in enumerate(m.cmds):
        p_pt, _ = m.dynamics.step(P[k].copy(), V[k].copy(), cmd, dt)
        err = np.linalg.norm(P[k + 1] - p_pt, axis=1)
        flying = crashed_at > k
        means.append(err[flying].mean())
        worst = max(worst, err[flying].max())
        every.append(err.mean())
    assert r.metrics["vehicle_track_err_mean"] == pytest.approx(np.mean(means), rel=1e-9)
    assert r.metrics["vehicle_track_err_max"] == pytest.approx(worst, rel=1e-12)
    # the held wrecks would have moved the figure: the test tells the two apart
    assert abs(np.mean(every) - np.mean(means)) > 1e-3 * np.mean(means)


class _Descend(_Hover):
    """Every agent of a 3-D scene asks to go down at 1.5 m/s^2 (at most 1 m/s) and drift along +x."""

    name = "descend"
    dims = (3,)

    def act(self, obs: Observation, rng):
        a = np.zeros((self.n, self.d))
        a[:, 0], a[:, 2] = 0.3, -1.5
        return a, {}


def _room(boundary):
    from swarmnav.world.scenario import from_dict

    return from_dict({"name": "room", "world": {"bounds": [0.0, 0.0, 0.0, 20.0, 10.0, 6.0], "boundary": boundary},
                      "swarm": {"n": 4, "spawn": [2.0, 2.0, 1.0, 8.0, 8.0, 2.0]}, "goal": {"position": [18.0, 5.0, 1.5]}})


@pytest.mark.parametrize("boundary", ["open", "wall"])
def test_a_quadrotor_that_comes_down_to_the_floor_crashes_there(boundary):
    r = swarmnav.run(_Descend(), _room(boundary), seed=1, steps=80, **QUAD)  # 4 s: down from 1-2 m at <= 1 m/s
    crashes = [e for e in r.events if e.get("action") == "crash"]
    assert len(crashes) == 4 and {e["reason"] for e in crashes} == {"ground"}
    assert r.metrics["crashes"] == 4.0 and np.isfinite(r.positions).all()
    z = r.positions[..., 2]
    assert z.min() >= 0.0  # nobody below the floor, at any recorded step
    for e in crashes:  # held where it came down, at rest
        i, k = e["agent"], e["step"]
        assert np.all(r.positions[k:, i] == r.positions[k, i]) and np.all(r.velocities[k + 1:, i] == 0.0)
    if boundary == "open":  # only the ground stops them: each is on it, at z = 0
        assert np.all(r.positions[-1, :, 2] == 0.0) and r.metrics["vehicle_grounded"] == 4.0
    else:  # the floor is a wall too: the referee's contact rule stops each a body radius above it
        z_end = r.positions[-1, :, 2]
        assert np.all((z_end > 0.0) & (z_end < r.config["rules"]["body_radius"])) and r.metrics["vehicle_grounded"] == 0.0


def test_there_is_no_ground_under_a_2d_scene_or_a_planar_method_at_its_altitude():
    flat = swarmnav.run(_Hover(), "default_corridor", seed=1, steps=20, **QUAD)  # held at the plane's altitude
    planar_method = _Push(40)
    planar_method.dims = (2,)  # a planar method: it flies the 3-D scene's slice at z_fly, over its floor at z = 0
    planar = swarmnav.run(planar_method, "sph_cluttered_3d", seed=1, steps=40, **QUAD)
    for r in (flat, planar):
        assert r.metrics["vehicle_grounded"] == 0.0
        assert not [e for e in r.events if e.get("reason") == "ground"]
    assert planar.config["plane"]["z_fly"] > 0.5 and np.all(planar.positions[..., 2] == planar.config["plane"]["z_fly"])
    assert planar.metrics["crashes"] == 0.0 and planar.metrics["vehicle_alt_err_max"] < 0.01


def _heading_run(yaw):
    """Two quadrotors of a 2-D scene asked to accelerate along +y and along (-1, -1) for 4 s,
    through the vehicle layer itself; their headings [deg] after every step and final positions."""
    from swarmnav.dynamics import SaturatedDoubleIntegrator
    from swarmnav.dynamics.vehicle import Quadrotors, vehicle_params

    p, w = vehicle_params({"vehicle": "quadrotor", "vehicle.yaw": yaw})
    q = Quadrotors(p, w, SaturatedDoubleIntegrator(1.0, 1.5), np.zeros((2, 2)), np.zeros((2, 2)), 0.05, 1)
    pos, vel, cmd = np.zeros((2, 2)), np.zeros((2, 2)), np.array([[0.0, 1.0], [-1.0, -1.0]])
    headings = []
    for _ in range(80):
        pos, vel = q.step(pos, vel, cmd, 0.05)
        headings.append(np.degrees(q.heading))
    return np.array(headings), pos, q.summary()


def test_yaw_velocity_turns_each_heading_toward_its_velocity_at_the_rate_limit():
    held, p_held, _ = _heading_run("hold")
    turned, p_turned, m = _heading_run("velocity")
    assert np.abs(held).max() < 1.0  # yaw held at 0 (the rotor drag couples a fraction of a degree in)
    # 45 deg/s (PX4's MPC_YAWRAUTO_MAX) from the first step with a velocity: 45 deg at ~1 s, the
    # one along +y at 90 deg from ~2 s on, the other the shorter way round, to -135 deg at ~3 s
    assert abs(turned[20, 0] - 45.0) < 3.0 and abs(turned[20, 1] + 45.0) < 3.0
    assert abs(turned[40, 0] - 90.0) < 3.0 and abs(turned[40, 1] + 90.0) < 3.0
    np.testing.assert_allclose(turned[-1], [90.0, -135.0], atol=0.5)
    t = 0.05 * np.arange(1, 81)
    assert np.all(turned[:, 0] <= 45.0 * t + 3.0) and np.all(turned[:, 1] >= -45.0 * t - 3.0)  # never ahead of the limit
    assert turned[:, 0].max() < 92.0 and turned[:, 1].min() > -137.0  # nor past the velocity's direction by > 2 deg
    # the heading is not the translation: the vehicles go where they went with the yaw held, to 1 cm
    assert np.abs(p_turned - p_held).max() < 0.01 and m["vehicle_flips"] == 0.0


def test_yaw_hold_is_the_run_as_before_and_velocity_is_recorded():
    a = swarmnav.run("apf", "default_corridor", seed=2, steps=30, **QUAD)
    b = swarmnav.run("apf", "default_corridor", seed=2, steps=30, **QUAD, **{"vehicle.yaw": "hold"})
    assert np.array_equal(a.positions, b.positions) and np.array_equal(a.thrust_axis, b.thrust_axis)
    assert "yaw" not in a.config["vehicle"] and a.config == {**b.config}  # a run's key as before the option
    c = swarmnav.run("apf", "default_corridor", seed=2, steps=30, **QUAD, **{"vehicle.yaw": "velocity"})
    assert c.config["vehicle"]["yaw"] == "velocity" and c.config["vehicle"]["yaw_rate_max"] == 45.0
    assert np.isfinite(c.positions).all() and not np.array_equal(a.thrust_axis, c.thrust_axis)
