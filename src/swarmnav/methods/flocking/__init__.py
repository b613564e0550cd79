"""The reactive flocking pair Swarmlab ships and the SPH paper compares against: Olfati-Saber's
Algorithm 3 (``olfati-saber``) and Vásárhelyi et al.'s optimised model (``vasarhelyi``).
docs/methods/flocking.md describes both."""

from swarmnav.methods.flocking import olfati_saber, vasarhelyi  # noqa: F401  (registers both)
