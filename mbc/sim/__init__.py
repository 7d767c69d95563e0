"""MuJoCo simulation of Digit: terrains, PD at the physics rate, pushes, randomization hooks; the closed-chain
Digit behind the same interface (`DigitSim(robot="digit_closed_chain")`)."""

from mbc.sim.closed_chain_sim import ClosedChainDigitSim
from mbc.sim.digit_sim import DigitSim, SimConfig
from mbc.sim.domain import DomainParams
from mbc.sim.terrain import TERRAINS, make_terrain

__all__ = ["TERRAINS", "ClosedChainDigitSim", "DigitSim", "DomainParams", "SimConfig", "make_terrain"]
