"""The LSC planner (Park, Kim et al., "Online Distributed Trajectory Planning for Quadrotor Swarm
with Feasibility Guarantee using Linear Safe Corridor", IEEE RA-L 2022), registered as ``lsc``."""

from swarmnav.methods.lsc.method import LscMethod
from swarmnav.methods.lsc.params import LscParams
from swarmnav.methods.registry import register

register("lsc", LscMethod, "LSC: piecewise Bernstein plans, safe flight corridors and linear safe corridors "
         "between agents, one QP per robot per replan (OSQP), priority-based goal planning.", params=LscParams)

__all__ = ["LscMethod", "LscParams"]
