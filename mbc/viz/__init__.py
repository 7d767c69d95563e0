"""Meshcat browser visualization and matplotlib plots of episodes."""

from mbc.viz.meshcat_viewer import MeshcatViewer
from mbc.viz.plots import save_all

__all__ = ["MeshcatViewer", "save_all"]
