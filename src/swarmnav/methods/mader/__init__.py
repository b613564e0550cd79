"""MADER (Tordesillas & How, "MADER: Trajectory Planner in Multi-Agent and Dynamic Environments",
IEEE T-RO 2021), for static obstacles and other agents, registered as method ``mader``."""

from swarmnav.methods.mader.method import MaderMethod
from swarmnav.methods.mader.params import MaderParams
from swarmnav.methods.registry import register

register("mader", MaderMethod, "MADER: B-spline hulls, separating planes as decision variables (IPOPT via CasADi), "
         "asynchronous check-recheck commits.", params=MaderParams)

__all__ = ["MaderMethod", "MaderParams"]
