"""MuJoCo simulation of Digit: terrains, PD at the physics rate, pushes, randomization hooks."""

from mbc.sim.digit_sim import DigitSim, SimConfig
from mbc.sim.domain import DomainParams
from mbc.sim.terrain import TERRAINS, make_terrain

__all__ = ["TERRAINS", "DigitSim", "DomainParams", "SimConfig", "make_terrain"]
