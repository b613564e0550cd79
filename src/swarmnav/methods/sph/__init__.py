"""SPH swarm navigation (Li et al., "Swarm Navigation Based on Smoothed Particle Hydrodynamics
in Complex Obstacle Environments", RA-L 2025), registered as method ``sph``."""

from swarmnav.methods.registry import register
from swarmnav.methods.sph.method import Sph
from swarmnav.methods.sph.params import SphParams

register("sph", Sph, "SPH swarm navigation: SPH coordination + per-robot B-spline planning + raycast split/merge.",
         params=SphParams)

__all__ = ["Sph", "SphParams"]
