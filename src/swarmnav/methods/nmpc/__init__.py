"""The predictive swarm of Soria, Schiano & Floreano ("Predictive control of aerial swarms in
cluttered environments", Nature Machine Intelligence 2021), distributed, registered as ``nmpc``."""

from swarmnav.methods.nmpc.method import NmpcMethod
from swarmnav.methods.nmpc.params import NmpcParams
from swarmnav.methods.registry import register

register("nmpc", NmpcMethod, "Predictive swarm (Soria et al. 2021): a nonlinear MPC per robot (IPOPT via CasADi) "
         "with migration, separation, cohesion and effort costs, neighbours' broadcast predictions and "
         "obstacles as constraints.", params=NmpcParams)

__all__ = ["NmpcMethod", "NmpcParams"]
