"""Model-based walking control for the Digit humanoid: ALIP foot placement, whole-body IK,
passivity-based inverse-dynamics QP, and model-assumption diagnostics."""

from mbc.errors import ConfigError, MbcError, ModelLoadError
from mbc.types import Command, JointCommand, RobotState

__all__ = ["Command", "ConfigError", "JointCommand", "MbcError", "ModelLoadError", "RobotState"]
