"""The ALIP state of the full robot: CoM and angular momentum about the stance contact point."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mbc.geometry import yaw_rotation
from mbc.pin_robot import PinRobot


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
    to_heading = yaw_rotation(yaw).T
    relative = to_heading @ (robot.com - contact_point_world)
    momentum = to_heading @ robot.angular_momentum_about(contact_point_world)
    return AlipState(x=relative[:2], L=np.array([momentum[1], -momentum[0]]), com_height=float(relative[2]),
                     com_velocity=to_heading @ robot.com_velocity)
