"""Figures, animations and replay viewers made from stored results (never from a live simulation)."""

from swarmnav.viz.animate import animate_run
from swarmnav.viz.draw import draw_scene
from swarmnav.viz.perspective import plot_perspective
from swarmnav.viz.plot import plot_run, plot_scene
from swarmnav.viz.viewer import write_viewer

__all__ = ["animate_run", "draw_scene", "plot_perspective", "plot_run", "plot_scene", "write_viewer"]
