"""Model-based walking control for the Digit humanoid: ALIP foot placement, whole-body IK,
passivity-based inverse-dynamics QP, and model-assumption diagnostics.

    from mbc import AlipController, AlipModel, Command, DigitSim
"""

from mbc.alip import AlipModel
from mbc.errors import ConfigError, MbcError, ModelLoadError
from mbc.types import Command, Controller, JointCommand, RobotState

_LAZY = {"AlipController": "mbc.controller", "DigitSim": "mbc.sim", "run_episode": "mbc.rollout"}


def __getattr__(name: str):
    """Import the controller and simulator (placo, proxsuite, casadi, MuJoCo) only when asked for."""
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'mbc' has no attribute {name!r}")


__all__ = ["AlipController", "AlipModel", "Command", "ConfigError", "Controller", "DigitSim", "JointCommand", "MbcError",
           "ModelLoadError", "RobotState", "run_episode"]
