"""Maps between the closed-chain Digit and the open chain that controllers see.

The open chain's leg is six joints from the pelvis to a foot frame at the ankle; the closed chain's
is six motors, five passive hinges (two of them springs) and three ball-jointed rods closed by
`connect` constraints. The two meet at the feet: the open-chain joints that describe a closed-chain
state are those that put each open-chain foot frame (`{side}_foot` body) exactly where the closed
chain's foot is (`{side}_foot_frame` site: the ankle, oriented like the sole), relative to the
pelvis. Matching joint by joint instead would put the controller's feet centimetres from the real
ones: the closed chain's hip-to-ankle distance changes with its knee, the open chain's thigh is rigid.

* state map, closed -> open: foot pose relative to the pelvis -> open-chain leg IK (6 joints, 6D);
* pose map, open -> closed: open-chain forward kinematics of joint positions -> the loop's inverse
  kinematics (motors and passive joints, springs at rest, constraints closed): where `set_state` puts
  the closed chain (commands are torques, `mbc.sim.closed_chain_sim`, not poses);
* motor Jacobian M = d q_open / d q_motor (6 x 6 per leg) with the loops closed and springs rigid:
  rates map as qd_open = M qd_motor, torques as tau_motor = M^T tau_open (virtual work), and
  joint stiffness K_open as K_motor = M^T K_open M.

All solves are Gauss-Newton with minimum-norm steps (a rod's spin about its own axis is free),
warm-started from the previous solution, on scratch `MjData` with the pelvis at the origin.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from mbc.errors import MbcError
from mbc.robot import digit_mjspec
from mbc.sim.closed_chain_model import SIDES, SPRING_JOINTS, closed_chain_mjspec, side_bodies
from robots.digit import constants as digit

_TOLERANCE = 1e-10
"""Squared residual norm at which a solve stops [m^2, rad^2]."""
_MAX_ITERATIONS = 20
_DAMPING = 1e-8
"""Levenberg damping of the Gauss-Newton steps: bounded steps where a target is out of reach."""


def min_norm_step(jacobian: np.ndarray, residual: np.ndarray, damping: float = _DAMPING) -> np.ndarray:
    """dx minimizing |J dx + r|^2 + damping |dx|^2 (the minimum-norm Gauss-Newton step): -J^T (J J^T + damping)^-1 r."""
    gram = jacobian @ jacobian.T
    gram.flat[::len(gram) + 1] += damping
    return -jacobian.T @ np.linalg.solve(gram, residual)


def rotation_error(target: np.ndarray, current: np.ndarray) -> np.ndarray:
    """Rotation vector of target @ current^T [rad] (world frame): the small rotation taking current to target."""
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, (target @ current.T).ravel())
    error = np.empty(3)
    mujoco.mju_quat2Vel(error, quat, 1.0)
    return error


@dataclass(frozen=True)
class FootPose:
    """A foot frame relative to the pelvis: position [m] and rotation matrix."""

    pos: np.ndarray
    rot: np.ndarray

    def error_from(self, pos: np.ndarray, rot: np.ndarray) -> np.ndarray:
        """(6,) [position error; rotation vector] taking (pos, rot) to this pose."""
        return np.concatenate((self.pos - pos, rotation_error(self.rot, rot)))


class OpenChainLegs:
    """Forward and inverse kinematics of the open chain's legs (its own MuJoCo model, pelvis at the origin)."""

    def __init__(self) -> None:
        self.model = digit_mjspec().compile()
        self.data = mujoco.MjData(self.model)
        self.data.qpos[3] = 1.0
        ids = [self.model.joint(name).id for name in digit.JOINT_NAMES]
        self.qadr, self.dofadr = self.model.jnt_qposadr[ids], self.model.jnt_dofadr[ids]
        self.feet = [self.model.body(name).id for name in digit.FOOT_LINKS]
        self._jacp, self._jacr = np.zeros((3, self.model.nv)), np.zeros((3, self.model.nv))

    def _set(self, q: np.ndarray) -> None:
        self.data.qpos[self.qadr] = q
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_comPos(self.model, self.data)

    def foot_poses(self, q: np.ndarray) -> list[FootPose]:
        """Both feet at joint positions `q` (12,)."""
        self._set(q)
        return [FootPose(self.data.xpos[b].copy(), self.data.xmat[b].reshape(3, 3).copy()) for b in self.feet]

    def jacobian(self, side: int) -> np.ndarray:
        """(6, 6) foot twist [v; w] (pelvis frame) per rate of that leg's joints, at the last configuration."""
        mujoco.mj_jacBody(self.model, self.data, self._jacp, self._jacr, self.feet[side])
        cols = self.dofadr[6 * side:6 * side + 6]
        return np.vstack([self._jacp[:, cols], self._jacr[:, cols]])

    def inverse(self, poses: list[FootPose], q_start: np.ndarray) -> np.ndarray:
        """Joint positions (12,) that put both feet at `poses` (as near as the legs reach), from `q_start`."""
        q = np.array(q_start, dtype=float)
        for _ in range(_MAX_ITERATIONS):
            self._set(q)
            done = True
            for side, pose in enumerate(poses):
                foot = self.feet[side]
                error = pose.error_from(self.data.xpos[foot], self.data.xmat[foot].reshape(3, 3))
                if error @ error > _TOLERANCE:
                    done = False
                    q[6 * side:6 * side + 6] += min_norm_step(self.jacobian(side), -error)
            if done:
                break
        return q


class ClosedChainLegs:
    """Loop kinematics of the closed chain's legs (a scratch copy of its model, pelvis at the origin)."""

    def __init__(self, model: mujoco.MjModel | None = None) -> None:
        self.model = model if model is not None else closed_chain_mjspec().compile()
        self.data = mujoco.MjData(self.model)
        m = self.model
        self.motor_qadr = np.array([m.jnt_qposadr[m.actuator_trnid[a, 0]] for a in range(m.nu)])
        self.motor_dofadr = np.array([m.jnt_dofadr[m.actuator_trnid[a, 0]] for a in range(m.nu)])
        self.sites = [m.site(f"{side}_foot_frame").id for side in SIDES]
        self.connects = [[i for i in range(m.neq) if m.eq_type[i] == mujoco.mjtEq.mjEQ_CONNECT
                          and m.eq(i).name.startswith(side)] for side in SIDES]
        leg_dofs, spring_dofs = [], []
        for side in SIDES:
            dofs = [d for d in range(6, m.nv) if m.joint(m.dof_jntid[d]).name.startswith(side)]
            springs = [m.jnt_dofadr[m.joint(f"{side}_{j}").id] for j in SPRING_JOINTS]
            leg_dofs.append(np.array(dofs))
            spring_dofs.append(np.array(springs))
        self.leg_dofs = leg_dofs
        """Per side, every dof of the leg (motors, passive hinges, springs, rods)."""
        self.loop_dofs = [np.array([d for d in dofs if d not in springs]) for dofs, springs in zip(leg_dofs, spring_dofs)]
        """Per side, the dofs a loop solve moves: all but the springs (held)."""
        self.leg_motor_dofs = [self.motor_dofadr[6 * s:6 * s + 6] for s in range(2)]
        self.leg_passive_dofs = [np.setdiff1d(loop, motors) for loop, motors in zip(self.loop_dofs, self.leg_motor_dofs)]
        """Per side, the loop dofs the motors do not drive directly (passive hinges and rods)."""
        self._jacp, self._jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        self._jacp2, self._jacr2 = np.zeros((3, m.nv)), np.zeros((3, m.nv))

    def set(self, qpos: np.ndarray) -> None:
        """Kinematics at `qpos` with the pelvis moved to the origin (world frame = pelvis frame)."""
        self.data.qpos[:] = qpos
        self.data.qpos[:7] = (0, 0, 0, 1, 0, 0, 0)
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_comPos(self.model, self.data)

    def foot_pose(self, side: int) -> FootPose:
        site = self.sites[side]
        return FootPose(self.data.site_xpos[site].copy(), self.data.site_xmat[site].reshape(3, 3).copy())

    def foot_jacobian(self, side: int) -> np.ndarray:
        """(6, nv) foot-frame twist [v; w] per dof rate."""
        mujoco.mj_jacSite(self.model, self.data, self._jacp, self._jacr, self.sites[side])
        return np.vstack([self._jacp, self._jacr])

    def loop_residual(self, side: int) -> tuple[np.ndarray, np.ndarray]:
        """(3 k,) gaps of the leg's connect constraints [m] and their (3 k, nv) Jacobian."""
        m, d = self.model, self.data
        gaps, rows = [], []
        for eq in self.connects[side]:
            b1, b2 = m.eq_obj1id[eq], m.eq_obj2id[eq]
            p1 = d.xpos[b1] + d.xmat[b1].reshape(3, 3) @ m.eq_data[eq, 0:3]
            p2 = d.xpos[b2] + d.xmat[b2].reshape(3, 3) @ m.eq_data[eq, 3:6]
            mujoco.mj_jac(m, d, self._jacp, self._jacr, p1, b1)
            mujoco.mj_jac(m, d, self._jacp2, self._jacr2, p2, b2)
            gaps.append(p1 - p2)
            rows.append(self._jacp - self._jacp2)
        return np.concatenate(gaps), np.vstack(rows)

    def solve(self, qpos: np.ndarray, free_dofs: list[np.ndarray], targets: list[FootPose | None],
              strict: bool = False) -> np.ndarray:
        """Close each leg's loops (and put its foot at `targets[side]` unless None) by moving `free_dofs[side]`;
        where that is out of reach, the least-squares compromise, or an `MbcError` if `strict`."""
        qpos = np.array(qpos, dtype=float)
        base = qpos[:7].copy()
        step = np.zeros(self.model.nv)
        for _ in range(_MAX_ITERATIONS):
            self.set(qpos)
            step[:] = 0.0
            worst = 0.0
            for side in range(2):
                residual, jacobian = self.loop_residual(side)
                if targets[side] is not None:
                    pose = self.foot_pose(side)
                    residual = np.concatenate((residual, -targets[side].error_from(pose.pos, pose.rot)))
                    jacobian = np.vstack([jacobian, self.foot_jacobian(side)])
                worst = max(worst, float(residual @ residual))
                cols = free_dofs[side]
                step[cols] = min_norm_step(jacobian[:, cols], residual)
            if worst < _TOLERANCE:
                break
            mujoco.mj_integratePos(self.model, qpos, step, 1.0)
        else:
            if strict:
                raise MbcError(f"closed-chain loop solve did not converge (squared residual {worst:.2e})")
        qpos[:7] = base
        return qpos

    def motor_jacobian(self, side: int, open_jacobian: np.ndarray) -> np.ndarray:
        """M = d q_open / d q_motor (6, 6) at the last configuration, loops closed, springs rigid.

        Passive rates follow the motors through the constraints, Jc_p qd_p = -Jc_m qd_m (minimum norm:
        a rod's spin is free); the foot's twist G qd_m = J_foot,m qd_m + J_foot,p qd_p; the open chain's
        joints then move as J_open^-1 G qd_m."""
        motors, passive, passive_per_motor = self._passive_per_motor(side)
        foot = self.foot_jacobian(side)
        twist_per_motor = foot[:, motors] + foot[:, passive] @ passive_per_motor
        return np.linalg.solve(open_jacobian, twist_per_motor)

    def leg_rates(self, side: int, motor_rates: np.ndarray) -> np.ndarray:
        """Rates of every dof of the leg (`leg_dofs[side]` order) that the motors' rates drive, springs still."""
        motors, passive, passive_per_motor = self._passive_per_motor(side)
        rates = np.zeros(self.model.nv)
        rates[motors], rates[passive] = motor_rates, passive_per_motor @ motor_rates
        return rates[self.leg_dofs[side]]

    def _passive_per_motor(self, side: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(motor dofs, passive dofs, d passive / d motor) with the loops closed: Jc_p dp = -Jc_m dm."""
        _, constraint = self.loop_residual(side)
        motors, passive = self.leg_motor_dofs[side], self.leg_passive_dofs[side]
        return motors, passive, min_norm_step(constraint[:, passive], constraint[:, motors], damping=0.0)


def stand_qpos(legs: ClosedChainLegs) -> np.ndarray:
    """Digit's nominal stand (`reset_qpos` hinge angles, springs at their stand deflection), loops closed by
    moving the rods and the passive tarsus and toe joints."""
    m = legs.model
    qpos = m.qpos0.copy()
    for side in SIDES:
        leg, _ = side_bodies(side)
        for body in leg:
            if body.joint in ("hinge", "-hinge"):
                qpos[m.jnt_qposadr[m.joint(f"{side}_{body.name}").id]] = np.deg2rad(body.stand_deg)
    passive = ("achilles_rod", "toe_a_rod", "toe_b_rod", "tarsus", "toe_pitch", "toe_roll")
    free = [np.concatenate([_dofs(m, f"{side}_{name}") for name in passive]) for side in SIDES]
    return legs.solve(qpos, free, [None, None], strict=True)


def _dofs(model: mujoco.MjModel, joint: str) -> np.ndarray:
    j = model.joint(joint).id
    count = 3 if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL else 1
    return np.arange(model.jnt_dofadr[j], model.jnt_dofadr[j] + count)

