"""Environment steps per second: swarmnav.env beside VMAS on the same task (issue 20).

The task: 20 agents, each with a 360-ray LiDAR ring (range 20 m), among 12 boxes, random
actions. Ours: ``SwarmEnv`` (one copy; observation = 36 rays pooled from the 360-ray ring,
velocity, goal vector, 6 neighbours; reward and the simulator's clearance and contact checks)
and ``SwarmVectorEnv`` with 64 copies (one array call per step). VMAS: the same 12 boxes as
VMAS ``Box`` landmarks and 20 agents carrying a VMAS ``Lidar`` of 360 rays (range 20) that sees
the boxes, its observation (position, velocity, the 360 ranges) read every step as a VMAS
scenario does, ``num_envs`` = 1 and 64 on the CPU. VMAS also resolves collisions (its physics
engine), which ours does not (the simulator only counts contacts); its step therefore does
somewhat more work, which the table states beside the figures.

One core: the process is pinned to CPU 0 and PyTorch to one thread. Figures are env steps per
second, where a step of B copies counts as B env steps (the usual vectorised figure). VMAS is
optional (``pip install -e '.[bench-vmas]'``): without it the script says so and prints ours only.

    python benchmarks/bench_env.py [--steps 2000] [--vmas-steps 100]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

try:
    import swarmnav  # noqa: F401
except ImportError:  # running from a checkout without installing
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from swarmnav.env import SwarmEnv, SwarmVectorEnv
from swarmnav.world import from_dict

N_AGENTS = 20
N_RAYS = 360
RANGE = 20.0  # [m]
TARGET = 100.0  # ours / VMAS, issue 20
#: 12 boxes (centre x, centre y, length along x, width along y) [m] in a 50 x 24 m field
BOXES = [(x, y, 2.0, 2.0) for x in (4.0, 14.0, 24.0, 34.0) for y in (-7.0, 0.0, 7.0)]


def scene():
    """The task as a swarmnav scene: the boxes, the swarm spawned at the left, goal at the right."""
    return from_dict({
        "name": "bench_env_12_boxes",
        "world": {"bounds": [-12.0, -12.0, 46.0, 12.0]},
        "swarm": {"n": N_AGENTS, "spawn": [-10.0, -8.0, -4.0, 8.0]},
        "goal": {"position": [44.0, 0.0]},
        "obstacles": [{"type": "box", "min": [x - lx / 2, y - ly / 2], "max": [x + lx / 2, y + ly / 2]}
                      for x, y, lx, ly in BOXES],
    })


def rate_ours(copies: int, steps: int) -> float:
    """Env steps per second of swarmnav.env with ``copies`` copies (1: SwarmEnv)."""
    rng = np.random.default_rng(0)
    kw = dict(lidar_rays=N_RAYS, lidar_range=RANGE, horizon=1e5)
    if copies == 1:
        env = SwarmEnv(scene(), **kw)
        env.reset(seed=0)
        acts = rng.uniform(-1, 1, (steps, N_AGENTS, 2))
        env.step(acts[0])  # warm-up (numba compiled or loaded from cache)
        t0 = time.perf_counter()
        for k in range(steps):
            env.step(acts[k])
        return steps / (time.perf_counter() - t0)
    env = SwarmVectorEnv(copies, scene(), **kw)
    env.reset(seed=0)
    acts = rng.uniform(-1, 1, (steps, copies, N_AGENTS, 2))
    env.step(acts[0])
    t0 = time.perf_counter()
    for k in range(steps):
        env.step(acts[k])
    return copies * steps / (time.perf_counter() - t0)


def vmas_scenario():
    """The task as a VMAS scenario (None when VMAS is not installed)."""
    import torch
    from vmas.simulator.core import Agent, Box, Landmark, Sphere, World
    from vmas.simulator.scenario import BaseScenario
    from vmas.simulator.sensors import Lidar

    class LidarBoxes(BaseScenario):
        def make_world(self, batch_dim, device, **kwargs):
            world = World(batch_dim, device)
            self.boxes = []
            for i, (_, _, lx, ly) in enumerate(BOXES):
                box = Landmark(name=f"box_{i}", collide=True, movable=False, shape=Box(length=lx, width=ly))
                world.add_landmark(box)
                self.boxes.append(box)
            is_box = lambda e: e.name.startswith("box_")  # noqa: E731
            for i in range(N_AGENTS):
                world.add_agent(Agent(name=f"agent_{i}", collide=True, shape=Sphere(radius=0.2),
                                      sensors=[Lidar(world, n_rays=N_RAYS, max_range=RANGE, entity_filter=is_box,
                                                     render=False)]))
            self.goal = torch.tensor([44.0, 0.0], device=device)
            return world

        def reset_world_at(self, env_index=None):
            for box, (x, y, _, _) in zip(self.boxes, BOXES):
                box.set_pos(torch.tensor([x, y], device=self.world.device), batch_index=env_index)
            g = torch.Generator().manual_seed(0 if env_index is None else int(env_index))
            for k, agent in enumerate(self.world.agents):  # a 4 x 5 grid at the left, jittered
                base = torch.tensor([-9.0 + 1.5 * (k % 4), -6.0 + 3.0 * (k // 4)])
                n = self.world.batch_dim if env_index is None else 1
                pos = (base + 0.2 * torch.rand((n, 2), generator=g)).to(self.world.device)
                agent.set_pos(pos if env_index is None else pos[0], batch_index=env_index)

        def observation(self, agent):
            return torch.cat([agent.state.pos, agent.state.vel, agent.sensors[0].measure()], dim=-1)

        def reward(self, agent):
            return -torch.linalg.vector_norm(agent.state.pos - self.goal, dim=-1)

    return LidarBoxes()


def rate_vmas(copies: int, steps: int) -> float:
    """Env steps per second of VMAS on the same task with ``copies`` copies."""
    import torch
    import vmas

    env = vmas.make_env(vmas_scenario(), num_envs=copies, device="cpu", continuous_actions=True, seed=0)
    env.reset()
    gen = torch.Generator().manual_seed(0)
    acts = [[2 * torch.rand((copies, 2), generator=gen) - 1 for _ in range(N_AGENTS)] for _ in range(steps + 1)]
    env.step(acts[0])
    t0 = time.perf_counter()
    for k in range(steps):
        env.step(acts[k + 1])
    return copies * steps / (time.perf_counter() - t0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=2000, help="timed steps of ours per configuration")
    ap.add_argument("--vmas-steps", type=int, default=100, help="timed steps of VMAS per configuration")
    a = ap.parse_args()
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {0})
    try:
        import torch
        import vmas

        torch.set_num_threads(1)
        have_vmas = f"VMAS {vmas.__version__}, PyTorch {torch.__version__} (CPU, 1 thread)"
    except ImportError as e:
        have_vmas = None
        print(f"VMAS is not installed ({e}); pip install -e '.[bench-vmas]' to compare. Ours only.")
    print(f"task: {N_AGENTS} agents x {N_RAYS}-ray LiDAR (range {RANGE:g} m), {len(BOXES)} boxes, random "
          f"actions; one core{'; ' + have_vmas if have_vmas else ''}")
    print(f"{'copies':>6} {'swarmnav env steps/s':>22} {'VMAS env steps/s':>18} {'ratio':>8}")
    for copies in (1, 64):
        ours = rate_ours(copies, max(10, a.steps // (1 if copies == 1 else 16)))
        theirs = rate_vmas(copies, max(5, a.vmas_steps // (1 if copies == 1 else 4))) if have_vmas else None
        ratio = f"{ours / theirs:8.0f}x" if theirs else "       -"
        print(f"{copies:>6} {ours:>22.4g} {theirs if theirs else float('nan'):>18.4g} {ratio}")
        if theirs:
            print(f"       {'meets' if ours / theirs >= TARGET else 'MISSES'} the {TARGET:g}x target")


if __name__ == "__main__":
    main()
