"""The Vicsek family of HWVEM (Aerospace 2021): flocking navigation where one information UAV
knows the path. Six registered models share one implementation (:mod:`.model`):

- ``vem``: the classic Vicsek model, eq. (6);
- ``vem-a``: VEM with one information UAV flying the reference heading;
- ``ivem``: the improved Vicsek model, eq. (30)-(31);
- ``ivem-a``: IVEM, but neighbours of the information UAV average with weight 100 on it;
- ``wvem``: weighting Vicsek model, weights k_alpha / k_beta / k_gamma = 30 / 18 / 1;
- ``hwvem``: hierarchical weighting Vicsek model, eq. (9)-(17) (HWVEM-I by default; HWVEM-II
  is ``p1=0, p2=100``).

All of them use the obstacle-avoidance mechanism (Section 2.3) and the attraction/repulsion
terms (eq. 23-26) when the scene has obstacles and the coefficients are non-zero.
"""

from functools import partial

from swarmnav.methods.registry import register
from swarmnav.methods.vicsek.model import MODELS, WITH_INFO_UAV, VicsekFamily, VicsekParams, info_uav_index

_DESCRIPTIONS = {
    "vem": "Vicsek model (HWVEM eq. 6): align with the neighbours' mean heading; no information UAV.",
    "vem-a": "Vicsek model with one information UAV that knows the path (HWVEM Sec. 3.1.2).",
    "ivem": "Improved Vicsek model (HWVEM eq. 30-31): extremal agents turn by half the neighbours' spread.",
    "ivem-a": "IVEM with one information UAV, weight 100 for its neighbours (HWVEM Sec. 3.1.2).",
    "wvem": "Weighting Vicsek model: weights 30 / 18 / 1 for the information UAV, its neighbours, the rest.",
    "hwvem": "Hierarchical weighting Vicsek model (HWVEM eq. 9-17): layer-weighted alignment to one information UAV.",
}

for _name in MODELS:
    register(_name, partial(VicsekFamily, _name), _DESCRIPTIONS[_name], params=VicsekParams,
             navigation=_name in WITH_INFO_UAV)

__all__ = ["MODELS", "VicsekFamily", "VicsekParams", "info_uav_index"]
