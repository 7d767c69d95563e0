"""Pinocchio model and data kept in sync with a `RobotState`: frames, CoM, momentum, dynamics terms."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from mbc.robot import JointMap, load_pinocchio, pinocchio_configuration, pinocchio_velocity
from mbc.types import RobotState
from robots.digit import constants as digit


class PinRobot:
    """The Digit model in pinocchio; call `update(state)` once per tick, then query."""

    def __init__(self, model: pin.Model | None = None) -> None:
        self.model = model if model is not None else load_pinocchio()
        self.data = self.model.createData()
        self.joint_map = JointMap.for_pinocchio(self.model)
        self.mass = float(pin.computeTotalMass(self.model))
        self.sole_ids = tuple(self.model.getFrameId(name) for name in digit.SOLE_FRAMES)
        self.q = pin.neutral(self.model)
        self.v = np.zeros(self.model.nv)
        self._zero_acceleration = np.zeros(self.model.nv)

    def update(self, state: RobotState) -> None:
        """Forward kinematics, CoM, centroidal momentum and frame placements for `state`.

        Second-order kinematics at zero generalized acceleration, so frame accelerations read now
        are the drift terms Jdot v."""
        self.q = pinocchio_configuration(state.base_pos, state.base_quat, state.q, self.joint_map)
        self.v = pinocchio_velocity(state.base_quat, state.base_linvel, state.base_angvel, state.qd, self.joint_map)
        pin.forwardKinematics(self.model, self.data, self.q, self.v, self._zero_acceleration)
        pin.updateFramePlacements(self.model, self.data)
        pin.computeCentroidalMomentum(self.model, self.data)  # also the CoM, data.com[0]

    @property
    def com(self) -> np.ndarray:
        """(3,) whole-body CoM, world [m]."""
        return self.data.com[0].copy()

    @property
    def com_velocity(self) -> np.ndarray:
        """(3,) whole-body CoM velocity, world [m/s]: linear momentum / mass."""
        return self.data.hg.linear / self.mass

    def sole_position(self, side: int) -> np.ndarray:
        """(3,) sole frame origin of foot `side` (0 left, 1 right), world [m]."""
        return self.data.oMf[self.sole_ids[side]].translation.copy()

    def sole_pose(self, side: int) -> tuple[np.ndarray, np.ndarray]:
        """(3,) position [m] and (3, 3) rotation of the sole frame of foot `side`, world."""
        placement = self.data.oMf[self.sole_ids[side]]
        return placement.translation.copy(), placement.rotation.copy()

    def sole_velocity(self, side: int) -> np.ndarray:
        """(6,) sole frame linear and angular velocity, world-aligned axes."""
        return pin.getFrameVelocity(self.model, self.data, self.sole_ids[side], pin.LOCAL_WORLD_ALIGNED).vector.copy()

    def sole_horizontal_speed(self, side: int) -> float:
        """Horizontal speed of the sole frame origin of foot `side`, world [m/s]."""
        vx, vy, _ = pin.getFrameVelocity(self.model, self.data, self.sole_ids[side], pin.LOCAL_WORLD_ALIGNED).linear.tolist()
        return math.hypot(vx, vy)

    def angular_momentum_about(self, point_world: np.ndarray) -> np.ndarray:
        """(3,) angular momentum about a fixed world point: L_com + (c - p) x m v_com [kg m^2/s]."""
        return np.array(self.momentum_about(point_world)[2])

    def momentum_about(self, point_world: np.ndarray) -> tuple[tuple[float, float, float], tuple[float, float, float],
                                                                tuple[float, float, float]]:
        """CoM minus the point [m], CoM velocity [m/s] and angular momentum about the point (as in
        `angular_momentum_about`) [kg m^2/s], world axes, as float triples: the control tick's form."""
        px, py, pz = point_world.tolist()
        cx, cy, cz = self.data.com[0].tolist()
        hg = self.data.hg
        (hx, hy, hz), (kx, ky, kz) = hg.linear.tolist(), hg.angular.tolist()  # linear; angular about the CoM
        rx, ry, rz = cx - px, cy - py, cz - pz
        momentum = (kx + ry * hz - rz * hy, ky + rz * hx - rx * hz, kz + rx * hy - ry * hx)  # k + r x h
        return (rx, ry, rz), (hx / self.mass, hy / self.mass, hz / self.mass), momentum

    @property
    def centroidal_angular_momentum(self) -> np.ndarray:
        """(3,) angular momentum about the CoM, world-aligned axes [kg m^2/s]."""
        return self.data.hg.angular.copy()
