"""Random and corrupted robot states, for fuzzing controllers."""

from __future__ import annotations

import numpy as np

from mbc.types import RobotState
from robots.digit import constants as digit


def random_joint_positions(rng: np.random.Generator, shrink: float = 0.8) -> np.ndarray:
    """Joint positions drawn inside the (shrunk) joint ranges."""
    mid, half = (digit.Q_MAX_RAD + digit.Q_MIN_RAD) / 2, (digit.Q_MAX_RAD - digit.Q_MIN_RAD) / 2
    return mid + shrink * half * rng.uniform(-1, 1, digit.NUM_JOINTS)


def random_quaternion_wxyz(rng: np.random.Generator) -> np.ndarray:
    """A uniformly random unit quaternion, w x y z."""
    quat = rng.normal(size=4)
    return quat / np.linalg.norm(quat)


def random_robot_state(rng: np.random.Generator) -> RobotState:
    """A plausible, implausible or corrupted state (NaN joint, infinite velocity, zero quaternion,
    absurd joint speeds), for checking that a controller never raises and stays finite."""
    quat = rng.normal(size=4)
    state = RobotState(
        time=float(rng.uniform(0, 100)), base_pos=np.r_[rng.normal(size=2), rng.uniform(0.3, 1.3)],
        base_quat=quat / np.linalg.norm(quat) if rng.random() < 0.8 else np.r_[1.0, 0.1 * rng.normal(size=3)],
        base_linvel=rng.normal(scale=2, size=3), base_angvel=rng.normal(scale=3, size=3),
        q=rng.uniform(digit.Q_MIN_RAD, digit.Q_MAX_RAD), qd=rng.normal(scale=5, size=12),
        contact=rng.random(2) < 0.5)
    corruption = rng.integers(0, 6)
    if corruption == 1:
        state.q[rng.integers(12)] = np.nan
    elif corruption == 2:
        state.base_linvel[rng.integers(3)] = np.inf
    elif corruption == 3:
        state.base_quat = np.zeros(4)
    elif corruption == 4:
        state.qd *= 1e6
    return state
