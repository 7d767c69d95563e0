"""Small rotation and vector helpers for the control loop, in scalar maths.

numpy's general routines cost tens of microseconds on 3-vectors (np.cross about 40 us), which
adds up in a 200 Hz tick; these take one or two.
"""

from __future__ import annotations

import math

import numpy as np


def rotate_inverse(quat_wxyz: tuple[float, float, float, float], vector: np.ndarray) -> tuple[float, float, float]:
    """R(q)^T v for a unit quaternion q = (w, u): v - w t + u x t with t = 2 u x v."""
    w, x, y, z = quat_wxyz
    a, b, c = vector.tolist()
    tx, ty, tz = 2.0 * (y * c - z * b), 2.0 * (z * a - x * c), 2.0 * (x * b - y * a)
    return a - w * tx + y * tz - z * ty, b - w * ty + z * tx - x * tz, c - w * tz + x * ty - y * tx


def rotate_z(x: float, y: float, yaw: float) -> tuple[float, float]:
    """(x, y) rotated by `yaw` about z: numpy form `yaw_rotation(yaw)[:2, :2] @ [x, y]`."""
    cos_yaw, sin_yaw = math.cos(yaw), math.sin(yaw)
    return cos_yaw * x - sin_yaw * y, sin_yaw * x + cos_yaw * y


def yaw_of_quaternion(quat_wxyz: np.ndarray) -> np.ndarray | float:
    """Yaw [rad] of orientation(s) given as w x y z quaternions, shape (4,) or (n, 4)."""
    quat = np.asarray(quat_wxyz, dtype=float)
    single = quat.ndim == 1  # one orientation: Python floats, as the control loop wants
    w, x, y, z = quat.tolist() if single else np.moveaxis(quat, -1, 0)
    return (math.atan2 if single else np.arctan2)(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def yaw_of_rotation(rotation: np.ndarray) -> float:
    """Yaw [rad] of a (3, 3) rotation matrix: the heading of its x axis."""
    return math.atan2(rotation[1, 0], rotation[0, 0])


def yaw_rotation(yaw: float) -> np.ndarray:
    """(3, 3) rotation about world z by `yaw` [rad]."""
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])


def wrap_angle(angle: float) -> float:
    """`angle` wrapped to [-pi, pi) [rad]."""
    return (angle + math.pi) % (2 * math.pi) - math.pi
