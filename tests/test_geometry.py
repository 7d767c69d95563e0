"""The scalar rotation helpers of the control loop against numpy and pinocchio."""

import math

import numpy as np
import pinocchio as pin
import pytest

from mbc.fuzz import random_quaternion_wxyz
from mbc.geometry import rotate_inverse, wrap_angle, yaw_of_quaternion, yaw_of_rotation, yaw_rotation


def _unit_quaternions(rng, n):
    return np.array([random_quaternion_wxyz(rng) for _ in range(n)])


def test_rotate_inverse_is_the_transposed_rotation_matrix(rng):
    for quat, vector in zip(_unit_quaternions(rng, 10), rng.normal(size=(10, 3))):
        rotation = pin.Quaternion(*quat).toRotationMatrix()  # w, x, y, z
        np.testing.assert_allclose(rotate_inverse(tuple(quat), vector), rotation.T @ vector, atol=1e-12)


def test_yaw_of_quaternion_matrix_and_rotation_agree(rng):
    quats = _unit_quaternions(rng, 10)
    yaws = yaw_of_quaternion(quats)
    for quat, yaw in zip(quats, yaws):
        rotation = pin.Quaternion(*quat).toRotationMatrix()
        assert yaw_of_quaternion(quat) == pytest.approx(yaw, abs=1e-12)
        assert yaw_of_rotation(rotation) == pytest.approx(yaw, abs=1e-12)
    for yaw in (-3.0, -0.5, 0.0, 1.2, 3.1):
        assert yaw_of_rotation(yaw_rotation(yaw)) == pytest.approx(yaw, abs=1e-12)


def test_wrap_angle_range_and_identity():
    for angle in np.linspace(-10, 10, 41):
        wrapped = wrap_angle(angle)
        assert -math.pi <= wrapped < math.pi
        assert math.cos(wrapped) == pytest.approx(math.cos(angle)) and math.sin(wrapped) == pytest.approx(math.sin(angle))
