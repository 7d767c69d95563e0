"""Whole-body inverse kinematics on placo: joint targets from task-space targets.

Tasks, from the measured configuration (floating base free):
* stance sole: held where it is (soft, with a weight 1e3 above the others);
* swing sole: position and flat orientation with the heading yaw (soft, high weight);
* pelvis: upright with the heading yaw (soft); horizontal position at the measured one (weak),
  so the CoM keeps rolling over the stance foot as the ALIP dynamics says;
* CoM height above the stance sole at the ALIP model's z (soft);
* posture toward the nominal stand, and a small regularization.

`solve` returns q_des for this tick and qd_des from one more IK step toward the targets advanced
by one control period along their velocities.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import placo

from mbc.errors import ConfigError
from mbc.geometry import yaw_rotation
from mbc.robot import JointMap
from mbc.types import CONTROL_PERIOD_S
from robots.digit import constants as digit
from robots.digit.urdf import URDF_PATH


@dataclass(frozen=True)
class IkConfig:
    """IK task weights and iteration count."""

    iterations: int = 1
    """IK steps per tick toward the targets (each a small QP). The IK starts from the measured
    configuration every tick; a second step changed the mean walking velocities by at most 0.01 m/s
    (11 commands, 2 seeds); on 2 cm bumps 27 of 30 runs stayed up with one step, 28 with two."""
    stance_weight: float = 1e4
    """The stance sole's pose task: soft, 1e3 above the other tasks, which holds the sole as well as a
    hard task did (1e-8 m of drift per step in the IK test, as before). As a hard task placo eliminated
    it with a QR factorization every solve: 5% of the tick. A soft task also cannot make the IK infeasible."""
    swing_weight: float = 10.0
    pelvis_orientation_weight: float = 10.0
    com_height_weight: float = 10.0
    pelvis_xy_weight: float = 1.0
    posture_weight: float = 1e-3
    regularization: float = 1e-5
    convergence_tolerance_m: float = 0.02
    """Largest swing-position or CoM-height error [m] counted as converged."""

    def __post_init__(self) -> None:
        if self.iterations < 1:
            raise ConfigError(f"iterations must be >= 1, got {self.iterations}")


@dataclass
class IkTargets:
    """World-frame targets of one tick."""

    stance: int
    """0 left, 1 right."""
    swing_position: np.ndarray
    """(3,) swing sole position [m]."""
    swing_velocity: np.ndarray
    """(3,) swing sole velocity [m/s]."""
    swing_yaw: float
    ground_normal: np.ndarray
    """(3,) normal of the ground plane the swing foot lands on (its sole is laid on that plane)."""
    pelvis_yaw: float
    com_z_world_m: float
    """CoM z (world) [m]."""
    pelvis_xy: np.ndarray
    """(2,) pelvis horizontal position [m]."""
    pelvis_xy_velocity: np.ndarray


@dataclass
class IkResult:
    q_des: np.ndarray
    """(12,) joint positions [rad]."""
    qd_des: np.ndarray
    """(12,) joint velocities [rad/s]."""
    converged: bool
    swing_error_m: float
    com_height_error_m: float


def _pose(position: list[float], yaw: float, normal: np.ndarray) -> np.ndarray:
    """Pose with z along `normal` and x along the heading `yaw` projected onto that plane."""
    nx, ny, nz = normal.tolist()
    hx, hy = math.cos(yaw), math.sin(yaw)
    along = hx * nx + hy * ny
    xx, xy, xz = hx - along * nx, hy - along * ny, -along * nz  # heading minus its normal part
    norm = math.sqrt(xx * xx + xy * xy + xz * xz)
    xx, xy, xz = xx / norm, xy / norm, xz / norm
    yx, yy, yz = ny * xz - nz * xy, nz * xx - nx * xz, nx * xy - ny * xx  # y = z x x
    px, py, pz = position
    return np.array([[xx, yx, nx, px], [xy, yy, ny, py], [xz, yz, nz, pz], [0.0, 0.0, 0.0, 1.0]])


class WholeBodyIK:
    """Joint targets from task targets, with placo's kinematics solver."""

    def __init__(self, config: IkConfig | None = None, dt: float = CONTROL_PERIOD_S) -> None:
        self.config = cfg = config or IkConfig()
        self.dt = dt
        self.robot = placo.RobotWrapper(str(URDF_PATH), placo.Flags.ignore_collisions)
        self.joint_map = JointMap.for_pinocchio(self.robot.model)
        self.solver = placo.KinematicsSolver(self.robot)
        self.solver.mask_fbase(False)
        self.solver.enable_joint_limits(True)
        self.solver.dt = dt
        self._sole_tasks = [self.solver.add_frame_task(name, np.eye(4)) for name in digit.SOLE_FRAMES]
        self._pelvis_orientation = self.solver.add_orientation_task(digit.BASE_LINK, np.eye(3))
        self._pelvis_orientation.configure("pelvis_orientation", "soft", cfg.pelvis_orientation_weight)
        self._pelvis_xy = self.solver.add_position_task(digit.BASE_LINK, np.zeros(3))
        self._pelvis_xy.mask.set_axises("xy")
        self._pelvis_xy.configure("pelvis_xy", "soft", cfg.pelvis_xy_weight)
        self._com = self.solver.add_com_task(np.zeros(3))
        self._com.mask.set_axises("z")
        self._com.configure("com_height", "soft", cfg.com_height_weight)
        posture = self.solver.add_joints_task()
        posture.set_joints(dict(zip(digit.JOINT_NAMES, digit.Q_STAND.tolist())))
        posture.configure("posture", "soft", cfg.posture_weight)
        self.solver.add_regularization_task(cfg.regularization)
        self._stance = -1

    def _configure_stance(self, stance: int) -> None:
        if stance == self._stance:
            return
        self._sole_tasks[stance].configure("stance", "soft", self.config.stance_weight, self.config.stance_weight)
        self._sole_tasks[1 - stance].configure("swing", "soft", self.config.swing_weight, self.config.swing_weight)
        self._stance = stance

    def _set_fixed_targets(self, targets: IkTargets, stance_pose: np.ndarray) -> None:
        """The targets that do not move within the tick: stance foot, pelvis orientation, CoM height."""
        self._sole_tasks[targets.stance].T_world_frame = stance_pose
        self._pelvis_orientation.R_world_frame = yaw_rotation(targets.pelvis_yaw)
        self._com.target_world = np.array([0.0, 0.0, targets.com_z_world_m])

    def _set_moving_targets(self, targets: IkTargets, ahead_s: float) -> None:
        """Swing sole pose and pelvis position, `ahead_s` along their velocities."""
        (x, y), (vx, vy) = targets.pelvis_xy.tolist(), targets.pelvis_xy_velocity.tolist()
        self._pelvis_xy.target_world = np.array([x + ahead_s * vx, y + ahead_s * vy, 0.0])  # placo copies its targets
        swing = [p + ahead_s * v for p, v in zip(targets.swing_position.tolist(), targets.swing_velocity.tolist())]
        self._sole_tasks[1 - targets.stance].T_world_frame = _pose(swing, targets.swing_yaw, targets.ground_normal)

    def solve(self, q_measured: np.ndarray, targets: IkTargets) -> IkResult:
        """IK from the measured pinocchio configuration `q_measured` toward `targets`."""
        robot = self.robot
        robot.state.q = q_measured  # copied by placo
        robot.update_kinematics()
        self._configure_stance(targets.stance)
        stance_name = digit.SOLE_FRAMES[targets.stance]
        self._set_fixed_targets(targets, robot.get_T_world_frame(stance_name))
        self._set_moving_targets(targets, 0.0)
        for _ in range(self.config.iterations):
            self.solver.solve(True)
            robot.update_kinematics()
        q_now = robot.state.q.copy()  # the getter is a view on placo's state
        swing_error = math.dist(robot.get_T_world_frame(digit.SOLE_FRAMES[1 - targets.stance])[:3, 3].tolist(),
                                targets.swing_position.tolist())
        com_error = robot.com_world()[2].item() - targets.com_z_world_m
        self._set_moving_targets(targets, self.dt)
        self.solver.solve(True)
        q_ahead = robot.state.q
        q_des = q_now[self.joint_map.q]
        qd_des = (q_ahead[self.joint_map.q] - q_des) / self.dt
        tol = self.config.convergence_tolerance_m
        converged = swing_error < tol and abs(com_error) < tol  # False for NaN errors too
        return IkResult(q_des=q_des, qd_des=qd_des, converged=converged, swing_error_m=swing_error,
                        com_height_error_m=com_error)
