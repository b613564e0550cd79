"""The ``hes`` method end to end: structural events in a short run, encircling the goal, the
decision-source seam, occlusion wiring, ablation switches and parameter errors."""

import numpy as np
import pytest

import swarmnav
from swarmnav.methods import registry
from swarmnav.methods.base import Observation
from swarmnav.methods.hes import Hes, Proposal
from swarmnav.methods.hes.control import occlusion
from swarmnav.methods.hes.decision import project
from swarmnav.methods.hes.step import Step
from swarmnav.sim import RunResult
from swarmnav.world import from_dict

OPEN = {"name": "open", "swarm": {"n": 8, "spawn": [-3.0, -3.0, 3.0, 3.0]}, "goal": {"position": [20.0, 0.0]}}


def test_short_default_corridor_run_splits_and_merges(tmp_path):
    res = swarmnav.run("hes", "default_corridor", seed=1, steps=400)
    actions = [e["action"] for e in res.events]
    assert "split" in actions and "merge" in actions
    assert all(e["source"] == "rule" and e["reason"] for e in res.events)
    assert res.metrics["N_swarm"] > 1.0 and res.metrics["N_event"] == len(actions)
    assert res.metrics["llm_calls"] == 0.0 and res.metrics["llm_fallback_used"] == 0.0
    # labels change exactly where the events are logged
    changed = np.flatnonzero(np.any(res.labels[1:] != res.labels[:-1], axis=1))
    assert {e["step"] for e in res.events} <= set(changed.tolist()) | {0}
    out = res.save(tmp_path / "run")
    back = RunResult.load(out)
    assert [(e["step"], e["action"]) for e in back.events] == [(e["step"], e["action"]) for e in res.events]


def test_encircles_the_goal_at_r_enc():
    res = swarmnav.run("hes", from_dict(OPEN), seed=3, steps=350)
    d = np.linalg.norm(res.positions[-1] - np.array([20.0, 0.0]), axis=1)
    p = Hes().params
    assert np.all(np.abs(d - p.core.r_enc) < 0.6)  # on the ring (eq. 12: encircle within r_in)
    assert res.metrics["R_goal"] == 1.0
    ang = np.sort(np.arctan2(*(res.positions[-1] - [20.0, 0.0]).T[::-1]))
    assert np.diff(ang).min() > 0.3  # spread around the goal, not bunched


def test_orbiting_ring_keeps_the_swarm_moving_on_the_circle():
    # enc_orbit: the slots circulate at v_s; fixed slots (the default) leave the ring at rest
    p = Hes().params
    speed = {}
    for orbit in (False, True):
        res = swarmnav.run("hes", from_dict(OPEN), seed=3, steps=500, enc_orbit=orbit)
        v = np.linalg.norm(res.velocities[-50:], axis=2)  # the last 5 s, on the ring
        speed[orbit] = float(v.mean())
        d = np.linalg.norm(res.positions[-1] - np.array([20.0, 0.0]), axis=1)
        assert res.metrics["R_goal"] == 1.0 and np.all(np.abs(d - p.core.r_enc) < 2.5)  # about the ring
        if orbit:  # every agent turns the same way round the goal (counter-clockwise, omega > 0)
            rel = res.positions[-1] - [20.0, 0.0]
            vel = res.velocities[-1]
            assert np.all(rel[:, 0] * vel[:, 1] - rel[:, 1] * vel[:, 0] > 0.0)
    assert speed[False] < 0.2 * p.core.v_s
    assert speed[True] > 0.5 * p.core.v_s


class AlwaysSplit:
    """A decision source that proposes split at every step (an unruly LLM)."""

    def __init__(self):
        self.asked = 0

    def propose(self, z, step):
        self.asked += 1
        return Proposal("split", "always", "test")


def test_every_proposal_goes_through_the_projection():
    src = AlwaysSplit()
    m = Hes().use_source(src)
    res = swarmnav.run(m, "default_corridor", seed=2, steps=250)
    assert src.asked == 250
    splits = [e for e in res.events if e["action"] == "split"]
    assert len(splits) >= 1 and all(e["source"] == "test" for e in splits)
    assert res.metrics["hes_projected_to_keep"] == 250 - len(splits)  # infeasible ones became keep
    assert res.n_subswarms.max() <= Hes().params.core.max_subswarms


def test_decision_state_reads_reports_and_matches_feasibility():
    m = registry.make("hes")
    scn = swarmnav.load_scenario("default_corridor")
    x = np.array([[20.0 + 0.5 * (i % 4), -1.5 + i // 4] for i in range(20)], dtype=float)
    rng = np.random.default_rng(0)
    m.reset(scn, x, np.zeros_like(x), rng)
    m.act(Observation(0, 0.0, x, np.zeros_like(x)), rng)
    z = m.last_z
    assert z.S == 1 and z.n_c == 2  # the two branches around the separator
    assert z.w_min > 6.0 and z.can_split  # far from the goal, no cooldown yet
    assert project("split", z) == "split" and project("merge", z) == "keep"


def test_decision_state_counts_the_split_paths_of_every_report():
    """z(k)'s n_c, widths and distances, at every step of a run that splits and merges, as the
    public pieces give them: the largest len(split_paths) over the reports, and so on."""
    import math

    m = registry.make("hes")
    scn = swarmnav.load_scenario("default_corridor")
    rng = np.random.default_rng(1)
    x = scn.spawn_positions(rng)
    v = np.zeros_like(x)
    m.reset(scn, x, v, rng)
    seen_s, seen_nc = set(), set()
    for k in range(400):
        a, _ = m.act(Observation(k, k * m.dt, x, v), rng)
        step, z = m.last_step, m.last_z
        reps = m.last_reports if z.S == len(m.last_reports) else None
        if reps is not None:
            ids = sorted(reps)
            assert z.n_c == max(len(m.split_paths(step, reps[s])) for s in ids)
            widths = [c.width for s in ids for c in reps[s].corridors]
            assert z.w_max == (max(widths) if widths else 0.0) and z.w_min == (min(widths) if widths else 0.0)
            g = m.goal
            d = [math.hypot(*(reps[s].pack.centroid - g).tolist()) for s in ids]
            assert z.d_goal_avg == sum(d) / len(d)
            seen_s.add(z.S)
            seen_nc.add(z.n_c)
        x, v = m.dynamics.step(x, v, a, m.dt)
    assert len(seen_s) >= 2 and len(seen_nc) >= 2


def _occlusion(m, x, slot, nn, sl_idx, cent):
    """Eq. (30) as the control stage computes it, for the given couplings."""
    step = Step(0, x, np.zeros_like(x), np.zeros((len(x), 1)), slot=slot, nn=nn, sl_idx=sl_idx, cent=cent)
    occlusion(m, step)
    return step.sig


def test_occlusion_factor_of_each_target():
    scn = from_dict({**OPEN, "swarm": {"n": 2, "spawn": [-3.0, -3.0, 3.0, 3.0]},
                     "obstacles": [{"type": "box", "min": [1.0, -5.0], "max": [2.0, 5.0]}]})
    m = Hes()
    x = np.array([[0.0, 0.0], [3.0, 0.0]])
    m.reset(scn, x, np.zeros_like(x), np.random.default_rng(0))
    slot = np.array([[-1.0, 0.0], [4.0, 0.0]])  # both slots on the near side
    sig = _occlusion(m, x, slot, np.array([1, 0]), np.array([0, 0]), np.array([[1.5, 12.0], [1.5, 12.0]]))
    # columns: slot, nearest neighbour, subleader, centroid (agent 1's subleader is agent 0)
    np.testing.assert_array_equal(sig, [[1.0, 0.2, 1.0, 1.0], [1.0, 0.2, 0.2, 1.0]])
    m2 = Hes(occlusion_attenuation=False)
    m2.reset(scn, x, np.zeros_like(x), np.random.default_rng(0))
    assert np.all(_occlusion(m2, x, slot, np.array([1, 0]), np.array([0, 0]), x) == 1.0)


def test_ablation_switches():
    assert Hes().params.a_bound == 2.6 and Hes().params.adaptive
    off = Hes(safety_stack_off=True).params
    assert off.a_bound == off.ablation.a_max_relaxed and not off.adaptive and off.sigma == 0.2
    nob = Hes(acceleration_bound=False).params
    assert nob.a_bound == nob.ablation.a_max_relaxed and nob.adaptive
    assert Hes(occlusion_attenuation=False).params.sigma == 1.0


def test_parameter_errors():
    with pytest.raises(swarmnav.ConfigError, match="decision"):
        registry.make("hes", decision="gpt9")
    with pytest.raises(swarmnav.ConfigError, match="unknown parameter 'k_pp'"):
        registry.make("hes", k_pp=1.0)
    for k_p in (0.0, 1e-200):  # the formation scale spacing (k_p + k_path) / k_p must stay within R_L
        with pytest.raises(swarmnav.ConfigError, match=r"formation scale .* must be below paper.lidar_range"):
            registry.make("hes", **{"paper.k_p": k_p})
    with pytest.raises(swarmnav.ConfigError, match=r"paper.r_out > paper.r_in"):
        registry.make("hes", r_in=12.0)
    with pytest.raises(swarmnav.ConfigError, match=r"passage.band must be in \[0, inf\) m, got -1.0"):
        registry.make("hes", passage_band=-1.0)
    with pytest.raises(swarmnav.ConfigError, match=r"passage.relief must be < paper.d_safe"):
        registry.make("hes", passage_relief=1.5)
    assert registry.make("hes", decision="rule").params.decision == "rule"
