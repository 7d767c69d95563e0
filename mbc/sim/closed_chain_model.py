"""The closed-chain Digit as a MuJoCo spec, generated from `robots.digit.closed_chain_constants`.

Names: the torso body is `pelvis` and the toe-roll body `{side}_foot` (as the open chain's pelvis and
foot links), every other leg and arm body and each joint is `{side}_{name}`, motors are
`{side}_{joint}`; each foot has the open chain's `{side}_foot_box`
geom and `{side}_foot_touch` sensor, and a `{side}_foot_frame` site: at the toe-pitch joint (the
ankle), oriented like the foot box, i.e. the frame the open chain's `{side}_foot` link has.
Motors are `gear = 1` joint-torque actuators: the simulator computes each motor's torque (PD at the
physics rate, gear x motor torque limits, torque-speed limit, delay) and writes it as `ctrl`.
"""

from __future__ import annotations

import mujoco
import numpy as np

from mbc.robot import LOWER_CONAFFINITY, LOWER_CONTYPE, UPPER_CONAFFINITY, UPPER_CONTYPE
from robots.digit import closed_chain_constants as cc
from robots.digit import constants as digit

SIDES = digit.SIDES
SPRING_JOINTS = ("shin", "heel_spring")
ROD_BODIES = ("achilles_rod", "toe_a_rod", "toe_b_rod")


def euler_xyz_quat(euler_deg) -> np.ndarray:
    """Quaternion (w x y z) of intrinsic x-y-z Euler angles [deg] (MJCF `eulerseq='xyz'`)."""
    quat = np.array([1.0, 0.0, 0.0, 0.0])
    for axis, angle in enumerate(np.deg2rad(euler_deg)):
        q_axis = np.zeros(4)
        q_axis[0], q_axis[1 + axis] = np.cos(angle / 2), np.sin(angle / 2)
        mujoco.mju_mulQuat(quat, quat.copy(), q_axis)
    return quat


def _z_rotation(angle_deg: float) -> np.ndarray:
    half = np.deg2rad(angle_deg) / 2
    return np.array([np.cos(half), 0.0, 0.0, np.sin(half)])


def side_bodies(side: str) -> tuple[tuple[cc.Body, ...], tuple[cc.Body, ...]]:
    """(leg, arm) bodies of one side."""
    if side == "left":
        return cc.LEFT_LEG, cc.LEFT_ARM
    return tuple(map(cc.mirror, cc.LEFT_LEG)), tuple(map(cc.mirror, cc.LEFT_ARM))


def closed_chain_mjspec(springs: bool = True) -> mujoco.MjSpec:
    """The closed-chain Digit with a free-floating torso. `springs=False` makes the shin and heel
    springs rigid (their joints welded at zero), for measuring what the springs change."""
    spec = mujoco.MjSpec()
    spec.compiler.degree = False
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.option.timestep = cc.TIMESTEP_S
    spec.option.solver = mujoco.mjtSolver.mjSOL_NEWTON
    spec.option.iterations = cc.SOLVER_ITERATIONS
    spec.option.gravity = [0.0, 0.0, -cc.GRAVITY_MPS2]
    torso = spec.worldbody.add_body(name="pelvis", pos=[0, 0, cc.TORSO_HEIGHT_M], mass=cc.TORSO_MASS_KG,
                                    ipos=cc.TORSO_COM_M, fullinertia=_full_inertia(cc.TORSO_INERTIA))
    torso.add_freejoint(name="root")
    torso.add_geom(name="pelvis_box", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.1, 0.15, 0.2], pos=[0, 0, 0.2],
                   contype=UPPER_CONTYPE, conaffinity=UPPER_CONAFFINITY, rgba=[0.25, 0.3, 0.4, 1])
    torso.add_site(name="imu", pos=[0, 0, 0])
    for side in SIDES:
        leg, arm = side_bodies(side)
        for body in leg + arm:
            _add_body(spec, side, body)
        _add_leg_geoms(spec, side)
        for connect in cc.LEFT_CONNECTS:
            anchor = np.array(connect.anchor_m) * (1, 1 if side == "left" else -1, 1)
            spec.add_equality(type=mujoco.mjtEq.mjEQ_CONNECT, name=f"{side}_{connect.body2}",
                              objtype=mujoco.mjtObj.mjOBJ_BODY, name1=body_name(side, connect.body1),
                              name2=body_name(side, connect.body2), data=np.r_[anchor, np.zeros(9)],
                              solref=cc.EQUALITY_SOLREF, solimp=cc.EQUALITY_SOLIMP)
        if not springs:
            for joint in SPRING_JOINTS:
                spec.add_equality(type=mujoco.mjtEq.mjEQ_JOINT, name=f"{side}_{joint}_weld",
                                  objtype=mujoco.mjtObj.mjOBJ_JOINT, name1=f"{side}_{joint}",
                                  solref=cc.EQUALITY_SOLREF, solimp=cc.EQUALITY_SOLIMP)
        for motor in cc.LEG_MOTORS:
            name = f"{side}_{motor.joint}"
            spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT,
                              forcelimited=mujoco.mjtLimited.mjLIMITED_TRUE,
                              forcerange=[-motor.torque_limit_nm, motor.torque_limit_nm])
    return spec


def _full_inertia(inertia) -> list[float]:
    ixx, iyy, izz, ixy, ixz, iyz = inertia
    return [ixx, iyy, izz, ixy, ixz, iyz]


def body_name(side: str, name: str) -> str:
    """The spec's name of a body of the constants: the torso is `pelvis`, the toe roll `{side}_foot`."""
    return {cc.TORSO: "pelvis", "toe_roll": f"{side}_foot"}.get(name, f"{side}_{name}")


def _add_body(spec: mujoco.MjSpec, side: str, body: cc.Body) -> None:
    parent = spec.body(body_name(side, body.parent))
    quat = euler_xyz_quat(body.euler_deg)
    if body.joint.endswith("locked"):  # welded at the stand angle: the joint's rotation folded into the frame
        sign = -1.0 if body.joint.startswith("-") else 1.0
        mujoco.mju_mulQuat(quat, quat.copy(), _z_rotation(sign * body.stand_deg))
    child = parent.add_body(name=body_name(side, body.name), pos=body.pos_m, quat=quat, mass=body.mass_kg, ipos=body.com_m,
                            fullinertia=_full_inertia(body.inertia))
    name = f"{side}_{body.name}"
    if body.joint == "ball":
        child.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_BALL, damping=body.damping_nms)
        return
    if body.joint.endswith("locked"):
        return
    joint = child.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_HINGE,
                            axis=[0, 0, -1.0 if body.joint.startswith("-") else 1.0],
                            stiffness=body.stiffness_nm_per_rad, damping=body.damping_nms,
                            frictionloss=body.frictionloss_nm, armature=body.armature_kgm2,
                            solref_limit=cc.JOINT_SOLREFLIMIT)
    if body.range_deg is not None:
        joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
        joint.range = np.deg2rad(body.range_deg)


def _add_leg_geoms(spec: mujoco.MjSpec, side: str) -> None:
    """Foot box, touch sensor and foot-frame site on the toe roll; capsules for the links that can hit the
    ground (the thigh and shin bodies as the upper body, the tarsus as the lower leg); rods visual only."""
    sign = 1.0 if side == "left" else -1.0
    toe_roll = spec.body(body_name(side, "toe_roll"))
    box_pos = np.array(cc.FOOT_BOX_POS_M) * (1, sign, 1)
    box_quat = euler_xyz_quat(np.array(cc.FOOT_BOX_EULER_DEG) * (sign, 1, sign))
    toe_roll.add_geom(name=f"{side}_foot_box", type=mujoco.mjtGeom.mjGEOM_BOX, size=cc.FOOT_BOX_HALF_SIZE_M,
                      pos=box_pos, quat=box_quat, friction=cc.FOOT_FRICTION, contype=LOWER_CONTYPE[side],
                      conaffinity=LOWER_CONAFFINITY[side], rgba=[0.8, 0.5, 0.2, 1])
    toe_roll.add_site(name=f"{side}_foot_touch", type=mujoco.mjtGeom.mjGEOM_BOX, pos=box_pos, quat=box_quat,
                      size=np.asarray(cc.FOOT_BOX_HALF_SIZE_M) + 0.01, rgba=[0, 0, 0, 0])
    frame_quat = np.empty(4)  # the box is long in its y axis, pointing back: x forward is its -y (left), +y (right)
    mujoco.mju_mulQuat(frame_quat, box_quat, _z_rotation(-90.0 * sign))
    toe_roll.add_site(name=f"{side}_foot_frame", pos=[0, 0, 0], quat=frame_quat)
    spec.add_sensor(name=f"{side}_foot_touch", type=mujoco.mjtSensor.mjSENS_TOUCH,
                    objtype=mujoco.mjtObj.mjOBJ_SITE, objname=f"{side}_foot_touch")
    gray = [0.3, 0.35, 0.45, 1]
    spec.body(f"{side}_hip_pitch").add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, 0.12, 0, 0],
                                             size=[0.06, 0, 0], contype=UPPER_CONTYPE,
                                             conaffinity=UPPER_CONAFFINITY, rgba=gray)
    spec.body(f"{side}_shin").add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, 0.40, 0.02, 0],
                                        size=[0.04, 0, 0], contype=UPPER_CONTYPE, conaffinity=UPPER_CONAFFINITY,
                                        rgba=gray)
    spec.body(f"{side}_tarsus").add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0.05, 0, 0, 0.36, -0.035, 0],
                                          size=[0.03, 0, 0], contype=LOWER_CONTYPE[side],
                                          conaffinity=LOWER_CONAFFINITY[side], rgba=gray)
    for rod in (b for b in cc.LEFT_LEG if b.name in ROD_BODIES):  # uniform rods: the CoM halfway along x
        spec.body(f"{side}_{rod.name}").add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, size=[0.008, 0, 0],
                                                 fromto=[0, 0, 0, 2 * rod.com_m[0], 0, 0], contype=0, conaffinity=0,
                                                 rgba=[0.7, 0.7, 0.7, 1])
