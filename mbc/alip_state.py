"""The ALIP state of the full robot: CoM and angular momentum about the stance contact point."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mbc.pin_robot import PinRobot


def yaw_of_quaternion(quat_wxyz: np.ndarray) -> np.ndarray | float:
    """Yaw [rad] of orientation(s) given as w x y z quaternions, shape (4,) or (n, 4)."""
    w, x, y, z = np.moveaxis(np.asarray(quat_wxyz, dtype=float), -1, 0)
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return float(yaw) if np.ndim(yaw) == 0 else yaw


def yaw_rotation(yaw: float) -> np.ndarray:
    """(3, 3) rotation about world z by `yaw` [rad]."""
    cy, sy = np.cos(yaw), np.sin(yaw)
    return np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class AlipState:
    """ALIP coordinates in the heading frame (x forward, y left), about the stance contact point."""

    x: np.ndarray
    """(2,) horizontal CoM position relative to the contact point: sagittal, lateral [m]."""
    L: np.ndarray
    """(2,) pendulum angular momenta (m z x' for z' = 0): sagittal L_y, lateral -L_x [kg m^2/s]."""
    com_height: float
    """CoM height above the contact point [m]."""
    com_velocity: np.ndarray
    """(3,) CoM velocity in the heading frame [m/s]."""


def alip_state(robot: PinRobot, contact_point_world: np.ndarray, yaw: float) -> AlipState:
    """The ALIP state of `robot` (already `update`d) about `contact_point_world`, heading `yaw`."""
    rotation = yaw_rotation(yaw)
    relative = rotation.T @ (robot.com - contact_point_world)
    momentum = rotation.T @ robot.angular_momentum_about(contact_point_world)
    return AlipState(x=relative[:2], L=np.array([momentum[1], -momentum[0]]), com_height=float(relative[2]),
                     com_velocity=rotation.T @ robot.com_velocity)
