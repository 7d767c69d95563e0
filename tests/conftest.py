import numpy as np
import pytest

from robots.digit import constants as c


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(0)


def random_joint_positions(rng: np.random.Generator, shrink: float = 0.8) -> np.ndarray:
    """Joint positions drawn inside the (shrunk) joint ranges."""
    mid, half = (c.Q_MAX_RAD + c.Q_MIN_RAD) / 2, (c.Q_MAX_RAD - c.Q_MIN_RAD) / 2
    return mid + shrink * half * rng.uniform(-1, 1, c.NUM_JOINTS)


def random_quaternion_wxyz(rng: np.random.Generator) -> np.ndarray:
    quat = rng.normal(size=4)
    return quat / np.linalg.norm(quat)
