"""Figures and animations made from stored results (never from a live simulation)."""

from swarmnav.viz.animate import animate_run
from swarmnav.viz.draw import draw_scene
from swarmnav.viz.plot import plot_run, plot_scene

__all__ = ["animate_run", "draw_scene", "plot_run", "plot_scene"]
