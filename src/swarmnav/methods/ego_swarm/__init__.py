"""EGO-Swarm (Zhou, Wang, Gao et al., "EGO-Swarm: A Fully Autonomous and Decentralized Quadrotor
Swarm System in Cluttered Environments", ICRA 2021) on EGO-Planner's ESDF-free gradient-based
local planner (Zhou, Gao, Wang, Xu, RA-L 2020), registered as method ``ego-swarm``."""

from swarmnav.methods.ego_swarm.method import EgoSwarm
from swarmnav.methods.ego_swarm.params import EgoSwarmParams
from swarmnav.methods.registry import register

register("ego-swarm", EgoSwarm, "EGO-Swarm: per-robot ESDF-free B-spline planning (EGO-Planner) with a swarm "
         "collision cost against broadcast trajectories.", params=EgoSwarmParams)

__all__ = ["EgoSwarm", "EgoSwarmParams"]
