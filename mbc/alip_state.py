"""The ALIP state of the full robot: CoM and angular momentum about the stance contact point."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mbc.pin_robot import PinRobot


@dataclass
class AlipState:
    """ALIP coordinates in the heading frame (x forward, y left), about the stance contact point."""

    x: np.ndarray
    """(2,) horizontal CoM position relative to the contact point: sagittal, lateral [m]."""
    L: np.ndarray
    """(2,) pendulum angular momenta (m z x' for z' = 0): sagittal L_y, lateral -L_x [kg m^2/s]."""
    com_height_above_contact_m: float
    """Measured CoM height above the contact point [m]."""
    com_velocity: np.ndarray
    """(3,) CoM velocity in the heading frame [m/s]."""


def alip_state(robot: PinRobot, contact_point_world: np.ndarray, yaw: float) -> AlipState:
    """The ALIP state of `robot` (already `update`d) about `contact_point_world`, heading `yaw`."""
    return alip_state_of(*robot.momentum_about(contact_point_world), yaw)


def alip_state_of(offset: tuple[float, float, float], velocity: tuple[float, float, float],
                  momentum: tuple[float, float, float], yaw: float) -> AlipState:
    """The ALIP state from the CoM minus the contact point [m], the CoM velocity [m/s] and the angular momentum
    about the point [kg m^2/s] (world float triples, `PinRobot.momentum_about`'s or `DigitSim.momentum_about`'s),
    rotated by -yaw into the heading frame (scalar maths: this runs every control tick)."""
    cos_yaw, sin_yaw = math.cos(yaw), math.sin(yaw)
    (rx, ry, rz), (vx, vy, vz), (Lx, Ly, _) = offset, velocity, momentum
    return AlipState(
        x=np.array([cos_yaw * rx + sin_yaw * ry, -sin_yaw * rx + cos_yaw * ry]),
        L=np.array([-sin_yaw * Lx + cos_yaw * Ly, -(cos_yaw * Lx + sin_yaw * Ly)]),
        com_height_above_contact_m=rz,
        com_velocity=np.array([cos_yaw * vx + sin_yaw * vy, -sin_yaw * vx + cos_yaw * vy, vz]))
