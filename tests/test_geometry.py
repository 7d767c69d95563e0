"""The scalar helpers of the control loop (rotations, the PD inverse) against numpy and pinocchio."""

import math

import numpy as np
import pinocchio as pin
import pytest

from mbc.fuzz import random_quaternion_wxyz
from mbc.geometry import rotate_inverse, rotate_z, wrap_angle, yaw_of_quaternion, yaw_of_rotation, yaw_rotation
from mbc.pd import position_target_for_torque


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


def test_rotate_z_is_the_yaw_rotation_matrix(rng):
    for _ in range(20):
        x, y, yaw = rng.normal(size=3) * 3
        np.testing.assert_allclose(rotate_z(x, y, yaw), (yaw_rotation(yaw) @ [x, y, 0.0])[:2], atol=1e-12)


def test_position_target_for_torque_is_its_numpy_form_and_inverts_the_pd_law(rng):
    tau, qd_des, q, qd = (rng.normal(size=12) for _ in range(4))
    kp, kd = rng.uniform(50, 1000, 12), rng.uniform(1, 30, 12)
    q_des = np.array(position_target_for_torque(*(a.tolist() for a in (tau, qd_des, q, qd, kp, kd))))
    np.testing.assert_allclose(q_des, q + (tau - kd * (qd_des - qd)) / kp, rtol=1e-14)
    np.testing.assert_allclose(kp * (q_des - q) + kd * (qd_des - qd), tau, atol=1e-12)
