"""Imperfect perception (swarmnav/sensing/perception.py, docs/sensing.md): own-state noise and
drift, range noise, dropouts and field of view; seeded; perfect perception changes nothing; the
metrics keep the true state; bad input is one line."""

import json
import math

import numpy as np
import pytest

import swarmnav
from _helpers.cli import run_cli
from swarmnav.errors import ConfigError
from swarmnav.methods.base import Observation
from swarmnav.sensing import lidar_ring, ray_table, signed_distance
from swarmnav.sensing.perception import Perception, SenseParams, sense_params

MAX = 20.0  # [m] sensor range of the ring tests


def _walk(p: SenseParams, n=50, d=2, steps=200, dt=0.1, seed=3):
    """Own-state errors (steps, N, d) of agents at rest on a line, and the perception."""
    pos = np.c_[np.arange(n, dtype=float), np.zeros((n, d - 1))]
    vel = np.zeros((n, d))
    sense = Perception(p, pos, seed)
    errs = [np.subtract(sense.observe(k * dt, pos, vel), (pos, vel)) for k in range(steps)]
    return sense, np.array(errs)  # (steps, 2, N, d): position and velocity errors


def _ring(value: float, n: int, r: int = 360) -> np.ndarray:
    return np.full((n, r), value)


def _dirs(r: int = 360) -> np.ndarray:
    return np.column_stack(ray_table(r))


def test_own_state_noise_has_the_stated_mean_and_spread():
    _, e = _walk(SenseParams(pos_noise=0.1, vel_noise=0.2))
    pos, vel = e[:, 0], e[:, 1]  # 20 000 draws per axis each
    # std of a mean of 20 000 draws: 0.1 / 141 = 0.0007 m; tolerance 6 of them
    assert abs(pos.mean()) < 0.004 and abs(vel.mean()) < 0.008
    # std of a std estimate: sigma / sqrt(2 n) = 0.0005 m (0.001 m/s); tolerance 6 of them
    assert pos.std() == pytest.approx(0.1, abs=0.003) and vel.std() == pytest.approx(0.2, abs=0.006)
    # white: the error of one step says nothing of the next (lag-1 correlation of 20 000 pairs, 1/sqrt(n) = 0.007)
    assert abs(np.corrcoef(pos[1:].ravel(), pos[:-1].ravel())[0, 1]) < 0.04


def test_drift_grows_as_its_rate_times_time():
    _, e = _walk(SenseParams(drift=0.02), n=2000, steps=201)
    pos = e[:, 0]
    # the drift velocity is constant: every agent's error doubles from 10 s to 20 s, exactly linear
    assert np.allclose(pos[200], 2.0 * pos[100], rtol=1e-9, atol=1e-15)
    assert np.all(pos[0] == 0.0)
    # spread drift * t = 0.2 m per axis at 10 s; 4000 draws: std of the std 0.2 / sqrt(8000) = 0.0022 m
    assert pos[100].std() == pytest.approx(0.2, abs=0.012)
    assert np.all(e[:, 1] == 0.0)  # the velocity estimate is not touched by the drift


def test_range_noise_on_returns_that_hit_and_none_on_rays_that_hit_nothing():
    sense = Perception(SenseParams(range_noise=0.05), np.zeros((100, 2)), seed=1)
    ring = _ring(5.0, 100)
    ring[:, ::2] = MAX  # every second ray hits nothing
    got = sense.scan(lambda at: ring.copy(), np.zeros((100, 2)), _dirs(), MAX)
    noise = got[:, 1::2] - 5.0  # 18 000 returns
    assert abs(noise.mean()) < 0.003  # std of the mean 0.05 / 134 = 0.0004 m; 7 of them
    assert noise.std() == pytest.approx(0.05, abs=0.002)  # std of the std 0.00026 m
    assert np.all(got[:, ::2] == MAX)
    near = sense.scan(lambda at: _ring(0.01, 100), np.zeros((100, 2)), _dirs(), MAX)
    assert near.min() == 0.0 and near.max() <= MAX  # clipped to the sensor's interval


def test_dropout_loses_its_fraction_of_returns_as_no_return():
    n = 100
    sense = Perception(SenseParams(dropout=0.3), np.zeros((n, 2)), seed=2)
    lost = np.mean([sense.scan(lambda at: _ring(3.0, n), np.zeros((n, 2)), _dirs(), MAX) == MAX
                    for _ in range(10)])
    assert lost == pytest.approx(0.3, abs=0.005)  # 360 000 rays: std 0.0008
    assert sense.summary()["sense_returns_lost_fraction"] == pytest.approx(lost)


def test_field_of_view_masks_the_rays_behind_the_heading():
    pos = np.zeros((2, 2))
    sense = Perception(SenseParams(fov=90.0), pos, seed=0)
    sense.observe(0.0, pos, np.array([[1.0, 0.0], [0.0, -2.0]]))  # heading +x and -y
    got = sense.scan(lambda at: _ring(3.0, 2), pos, _dirs(), MAX)
    angle = np.degrees(np.arange(360) * 2 * np.pi / 360)
    seen_x = (angle <= 45.0) | (angle >= 315.0)
    seen_down = np.abs(angle - 270.0) <= 45.0
    assert np.array_equal(got[0] < MAX, seen_x) and np.array_equal(got[1] < MAX, seen_down)
    assert np.all(got[got < MAX] == 3.0)  # inside the view: the exact return
    # hovering keeps the last heading
    sense.observe(0.1, pos, np.zeros((2, 2)))
    assert np.array_equal(sense.scan(lambda at: _ring(3.0, 2), pos, _dirs(), MAX), got)


def test_field_of_view_is_a_cone_in_3d_and_starts_toward_the_goal():
    pos = np.zeros((1, 3))
    sense = Perception(SenseParams(fov=60.0), pos, seed=0, goal=np.array([0.0, 0.0, 10.0]))
    u = np.array([[0, 0, 1], [np.sin(0.5), 0, np.cos(0.5)], [np.sin(0.53), 0, np.cos(0.53)], [1, 0, 0], [0, 0, -1]])
    sense.observe(0.0, pos, np.zeros((1, 3)))  # at rest: the heading toward the goal (+z)
    got = sense.scan(lambda at: _ring(3.0, 1, 5), pos, u, MAX)
    assert got[0].tolist() == [3.0, 3.0, MAX, MAX, MAX]  # 0.5 rad < 30 deg < 0.53 rad


def test_rays_leave_from_the_true_position():
    scn = swarmnav.load_scenario("default_corridor")
    true = scn.spawn_positions(np.random.default_rng(0))
    sense = Perception(SenseParams(pos_noise=0.5), true, seed=4)
    est, _ = sense.observe(0.0, true, np.zeros_like(true))
    assert np.abs(est - true).max() > 0.1
    got = sense.scan(lambda at: lidar_ring(scn.geometry, at, 360, MAX), est, _dirs(), MAX)
    assert np.array_equal(got, lidar_ring(scn.geometry, true, 360, MAX))
    obs = Observation(0, 0.0, est, np.zeros_like(est), None, sense)
    assert np.array_equal(obs.scan(lambda at: lidar_ring(scn.geometry, at, 360, MAX), est, _dirs(), MAX), got)


def test_the_same_seed_draws_the_same_errors_and_own_state_errors_do_not_depend_on_scanning():
    p = SenseParams(pos_noise=0.1, drift=0.01, range_noise=0.1, dropout=0.2)
    _, a = _walk(p, seed=5)
    _, b = _walk(p, seed=5)
    _, c = _walk(p, seed=6)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    pos = np.zeros((4, 2))
    s1, s2 = Perception(p, pos, 5), Perception(p, pos, 5)
    for k in range(3):
        e1 = s1.observe(k * 0.1, pos, pos)[0]
        s1.scan(lambda at: _ring(3.0, 4), pos, _dirs(), MAX)  # s1 reads its sensor, s2 does not
        assert np.array_equal(e1, s2.observe(k * 0.1, pos, pos)[0])


def test_perfect_perception_is_no_perception():
    assert SenseParams().perfect and sense_params({}).perfect
    base = swarmnav.run("apf", "default_corridor", seed=2, steps=40)
    zero = swarmnav.run("apf", "default_corridor", seed=2, steps=40,
                        **{"sense.pos_noise": 0.0, "sense.dropout": 0.0, "sense.fov": 360})
    assert np.array_equal(base.positions, zero.positions) and np.array_equal(base.velocities, zero.velocities)
    assert base.metrics == zero.metrics and "sense" not in zero.config


def test_metrics_use_the_true_state():
    kw = dict(seed=2, steps=60)
    base = swarmnav.run("apf", "default_corridor", **kw)
    noisy = swarmnav.run("apf", "default_corridor", **kw, **{"sense.pos_noise": 1.0})
    assert noisy.config["sense"]["pos_noise"] == 1.0
    assert np.array_equal(noisy.positions[0], base.positions[0])  # the spawn: the method's own draws unchanged
    # the estimates jump by about 1.4 m a step (1 m per axis, drawn afresh); the recorded
    # positions are the vehicles': a damped double integrator moves at most a_max dt^2 / 2 + v dt
    steps = np.linalg.norm(np.diff(noisy.positions, axis=0), axis=2)
    assert steps.max() < 0.5
    # mean estimation error: Rayleigh mean sigma sqrt(pi / 2) = 1.253 m; 60 x N draws, tolerance 5 %
    assert noisy.metrics["sense_pos_error_mean"] == pytest.approx(math.sqrt(math.pi / 2), rel=0.05)
    # the clearance recorded is the true positions' (against the scene's obstacles and walls)
    scn = swarmnav.load_scenario("default_corridor")
    x = noisy.positions[-1]
    walls = np.minimum(x - scn.lower, scn.upper - x).min(axis=1)
    assert np.allclose(noisy.clearance[-1], np.minimum(signed_distance(scn.geometry, x), walls), atol=1e-12)
    assert not np.array_equal(noisy.positions, base.positions)  # and the noise did change the flight


def test_hes_flies_its_ring_through_perception(tmp_path):
    r = run_cli("run", "--method", "hes", "--scenario", "narrow_alternating_gates", "--horizon", "30",
                "--set", "sense.pos_noise=0.05", "--set", "sense.range_noise=0.02", "--set", "sense.dropout=0.1",
                "--out", str(tmp_path / "x"))
    assert r.returncode == 0, r.stderr
    cfg = json.loads((tmp_path / "x" / "config.json").read_text())
    met = json.loads((tmp_path / "x" / "metrics.json").read_text())
    assert cfg["sense"]["dropout"] == 0.1 and cfg["steps"] == 300
    assert met["sense_returns_lost_fraction"] == pytest.approx(0.1, abs=0.002)  # 300 x 20 x 360 rays


@pytest.mark.parametrize("setting, words", [
    ("sense.pos_noise=-0.1", "pos_noise"), ("sense.dropout=1.5", "dropout"), ("sense.fov=0", "fov"),
    ("sense.fov=400", "fov"), ("sense.drift=nan", "drift"), ("sense.blur=1", "unknown parameter 'blur'"),
])
def test_impossible_perception_is_one_line(setting, words):
    key, value = setting.split("=")
    with pytest.raises(ConfigError) as e:
        swarmnav.run("apf", "default_corridor", seed=1, steps=5, **{key: value})
    assert words in str(e.value) and "\n" not in str(e.value)


def test_impossible_perception_is_exit_2_on_the_command_line(tmp_path):
    r = run_cli("run", "--method", "apf", "--scenario", "default_corridor", "--steps", "5",
                "--out", str(tmp_path / "r"), "--set", "sense.dropout=1.5")
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "dropout" in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_a_method_without_a_range_sensor_is_refused_the_range_options_in_one_line(tmp_path):
    r = run_cli("run", "--method", "vem", "--scenario", "default_corridor", "--steps", "5",
                "--out", str(tmp_path / "r"), "--set", "sense.dropout=0.3")
    assert r.returncode == 2 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert "vem has no range sensor" in r.stderr and "sense.dropout" in r.stderr
    assert all(m in r.stderr for m in ("apf", "hes", "olfati-saber", "vasarhelyi"))
    ok = swarmnav.run("vem", "default_corridor", seed=1, steps=5, **{"sense.pos_noise": 0.1})  # own state: any method
    assert ok.config["sense"]["pos_noise"] == 0.1


def test_the_flocking_pair_reads_its_range_sensor_through_perception():
    kw = dict(seed=3, steps=40)
    errors = []
    for method in ("vasarhelyi", "olfati-saber"):
        base = swarmnav.run(method, "default_corridor", **kw)
        blind = swarmnav.run(method, "default_corridor", **kw, **{"sense.dropout": 1.0, "sense.pos_noise": 0.01})
        assert blind.metrics["sense_returns_lost_fraction"] == 1.0
        assert not np.array_equal(base.positions, blind.positions)  # blind to the walls it flies beside
        errors.append((blind.metrics["sense_pos_error_mean"], blind.metrics["sense_pos_error_max"]))
    # the same seed, the same own-state errors whatever the method (to rounding: (p + n) - p is n
    # up to an ulp of p, and the two methods fly to different p)
    assert errors[0] == pytest.approx(errors[1], rel=1e-12)


def test_run_keys_carry_perception_as_resolved():
    from swarmnav.experiments import plan
    from swarmnav.experiments.spec import from_dict

    base = {"name": "keys", "method": "apf", "scenario": "default_corridor", "n": 4, "steps": 5, "seeds": "1"}
    variants = [{"name": "plain"}, {"name": "zero", "params": {"sense.dropout": 0.0}},
                {"name": "a", "params": {"sense.dropout": "0.10"}}, {"name": "b", "params": {"sense.dropout": 0.1}},
                {"name": "c", "params": {"sense.dropout": 0.2}}]
    keys = {j.variant.name: j.key for j in plan(from_dict({**base, "variants": variants}, "k.toml", {}, None))}
    assert keys["plain"] == keys["zero"]  # perfect perception leaves the key as without it
    assert keys["a"] == keys["b"] != keys["c"] and keys["a"] != keys["plain"]


def test_methods_lists_the_perception_options_a_method_honours(capsys):
    from swarmnav.cli import main

    main(["methods", "hes"])
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("perception"))
    assert all(f"sense.{k}" in line for k in ("pos_noise", "vel_noise", "drift", "range_noise", "dropout", "fov"))
    assert "sense.fov [deg] (0, 360]" in line and "sense.drift [m/s] [0, 100]" in line
    assert "sense.map" not in line  # no map to build from scans
    main(["methods", "vem"])
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("perception"))
    assert "sense.pos_noise [m]" in line and "sense.dropout" not in line and "no range sensor" in line
    main(["methods", "sph"])  # no range sensor of its own, but the scans of its map from scans
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("perception"))
    assert "sense.map [-] known | scans" in line and "sense.scan_rate [Hz] (0, 1000]" in line
    assert "sense.scan_fill [m] [0, 100]" in line
    assert "sense.dropout" in line and "apply to the scans of sense.map=scans" in line


def test_the_network_carries_what_each_agent_believes_of_itself():
    from swarmnav.methods.apf import Apf

    class Recording(Apf):  # APF, keeping what it was given each step
        def reset(self, *args):
            self.seen = []
            super().reset(*args)

        def act(self, obs, rng):
            self.seen.append((obs.positions.copy(), obs.view))
            return super().act(obs, rng)

    m = Recording()
    r = swarmnav.run(m, "default_corridor", seed=2, steps=20, **{"sense.pos_noise": 0.3, "net.latency": 0.2})
    for k, (est, view) in enumerate(m.seen):
        assert np.abs(est - r.positions[k]).max() > 0.1  # the method sees estimates, the run records the truth
        assert np.array_equal(view.positions[np.arange(len(est)), np.arange(len(est))], est)  # its own: its estimate
    # what agent 0 holds of agent 5 at step 10 is agent 5's estimate sent 0.2 s (2 steps) earlier
    assert np.array_equal(m.seen[10][1].positions[0, 5], m.seen[8][0][5])
    assert not np.array_equal(m.seen[10][1].positions[0, 5], r.positions[8, 5])
