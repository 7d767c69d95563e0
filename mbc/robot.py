"""Loads the Digit model for pinocchio, placo and MuJoCo from the one URDF, with joint-order maps.

Configuration layouts differ between the libraries:

* pinocchio free-flyer: q = [p_world_base (3), quat x y z w (4), joints], v = [v_base_local (3),
  w_base_local (3), joint velocities];
* MuJoCo free joint: qpos = [p_world_base (3), quat w x y z (4), joints], qvel = [v_base_world (3),
  w_base_local (3), joint velocities].

Joint columns are located by name, never assumed, and tests check the maps both ways.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin

from mbc.errors import ModelLoadError
from mbc.geometry import rotate_inverse
from robots.digit import constants as digit
from robots.digit.urdf import URDF_PATH

# Collision bits: ground (1); upper body (collides with ground only); each lower leg collides with
# the ground and with the other lower leg, never with itself.
GROUND_CONTYPE, GROUND_CONAFFINITY = 1, 1
UPPER_CONTYPE, UPPER_CONAFFINITY = 1, 0
LOWER_CONTYPE = {"left": 1 | 2, "right": 1 | 4}
LOWER_CONAFFINITY = {"left": 4, "right": 2}
CONTACT_FRICTION = (1.0, 0.02, 0.001)
"""Sliding, torsional, rolling friction of the foot boxes and the ground (MuJoCo uses the max of the pair)."""


def _check_file(path: Path) -> Path:
    path = Path(path)
    if not path.is_file():
        raise ModelLoadError(f"robot model file not found: {path}")
    return path


def load_pinocchio(urdf_path: Path = URDF_PATH) -> pin.Model:
    """The free-flyer pinocchio model, with rotor inertia (armature) on the leg joints."""
    path = _check_file(urdf_path)
    try:
        model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    except (RuntimeError, ValueError) as exc:
        raise ModelLoadError(f"pinocchio could not parse {path}: {exc}") from exc
    joint_map = JointMap.for_pinocchio(model)
    armature = np.zeros(model.nv)
    armature[joint_map.v] = digit.ARMATURE_KGM2
    model.armature = armature
    return model


def digit_mjspec(urdf_path: Path = URDF_PATH) -> mujoco.MjSpec:
    """The robot as a MuJoCo spec: free-floating pelvis, PD actuators, foot sensors, contact bits.

    Actuators are affine: force = s (ctrl - Kp q - Kd qd), clipped to the torque limits, where the
    simulator sets ctrl = tau_ff + Kp q_des + Kd qd_des each control period, so the PD law runs at
    the simulation rate inside MuJoCo (and Kd is integrated implicitly with `implicitfast`).
    """
    path = _check_file(urdf_path)
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except ValueError as exc:
        raise ModelLoadError(f"MuJoCo could not parse {path}: {exc}") from exc
    spec.compiler.fusestatic = False
    spec.option.timestep = 0.001
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    pelvis = spec.body(digit.BASE_LINK)
    pelvis.add_freejoint(name="root")
    pelvis.add_geom(name="pelvis_box", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.1, 0.15, 0.2],
                    pos=[0, 0, 0.2], contype=UPPER_CONTYPE, conaffinity=UPPER_CONAFFINITY,
                    rgba=[0.25, 0.3, 0.4, 1])
    pelvis.add_site(name="imu", pos=[0, 0, 0])
    for side, foot in zip(digit.SIDES, digit.FOOT_LINKS):
        _add_leg_geoms(spec, side, foot)
    for j, name in enumerate(digit.JOINT_NAMES):
        spec.joint(name).armature = digit.ARMATURE_KGM2[j]
        spec.add_actuator(
            name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT,
            gaintype=mujoco.mjtGain.mjGAIN_FIXED, biastype=mujoco.mjtBias.mjBIAS_AFFINE,
            gainprm=[1.0] + [0.0] * 9, biasprm=[0.0, -digit.KP[j], -digit.KD[j]] + [0.0] * 7,
            forcelimited=mujoco.mjtLimited.mjLIMITED_TRUE,
            forcerange=[-digit.TORQUE_LIMIT_NM[j], digit.TORQUE_LIMIT_NM[j]],
        )
    return spec


def _add_leg_geoms(spec: mujoco.MjSpec, side: str, foot: str) -> None:
    """Name the foot box, give it contact settings and a touch sensor; add limb capsules."""
    links = digit.leg_links(side)
    foot_body = spec.body(foot)
    box = foot_body.first_geom()
    box.name = f"{foot}_box"
    box.contype, box.conaffinity = LOWER_CONTYPE[side], LOWER_CONAFFINITY[side]
    box.friction = CONTACT_FRICTION
    box.rgba = [0.8, 0.5, 0.2, 1]
    margin = 0.01
    foot_body.add_site(name=f"{foot}_touch", type=mujoco.mjtGeom.mjGEOM_BOX, pos=box.pos,
                       size=np.asarray(box.size) + margin, rgba=[0, 0, 0, 0])
    spec.add_sensor(name=f"{foot}_touch", type=mujoco.mjtSensor.mjSENS_TOUCH,
                    objtype=mujoco.mjtObj.mjOBJ_SITE, objname=f"{foot}_touch")
    thigh, shank = spec.body(f"{side}_thigh"), spec.body(f"{side}_shank")
    knee = np.array(links[3].offset_m)
    ankle = np.array(links[4].offset_m)
    thigh.add_geom(name=f"{side}_thigh_capsule", type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                   fromto=np.r_[np.zeros(3), 0.85 * knee], size=[0.06, 0, 0],
                   contype=UPPER_CONTYPE, conaffinity=UPPER_CONAFFINITY, rgba=[0.3, 0.35, 0.45, 1])
    shank.add_geom(name=f"{side}_shank_capsule", type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                   fromto=np.r_[np.zeros(3), 0.75 * ankle], size=[0.035, 0, 0],
                   contype=LOWER_CONTYPE[side], conaffinity=LOWER_CONAFFINITY[side], rgba=[0.3, 0.35, 0.45, 1])


def as_slice(indices) -> slice | np.ndarray:
    """A slice where the indices are consecutive (indexing with it is ~10x faster), else the array."""
    indices = np.asarray(indices)
    if np.array_equal(indices, np.arange(indices[0], indices[0] + len(indices))):
        return slice(int(indices[0]), int(indices[0]) + len(indices))
    return indices


@dataclass(frozen=True)
class JointMap:
    """Where the `JOINT_NAMES` columns sit in a library's configuration and velocity vectors.

    `q` and `v` are slices when the columns are consecutive (they are, for the generated URDF).
    """

    q: slice | np.ndarray
    """The 12 positions in the configuration vector."""
    v: slice | np.ndarray
    """The 12 velocities in the velocity vector."""

    @classmethod
    def for_pinocchio(cls, model: pin.Model) -> JointMap:
        ids = [model.getJointId(name) for name in digit.JOINT_NAMES]
        if any(i >= model.njoints for i in ids):
            missing = [n for n, i in zip(digit.JOINT_NAMES, ids) if i >= model.njoints]
            raise ModelLoadError(f"pinocchio model lacks joints {missing}")
        return cls(q=as_slice([model.idx_qs[i] for i in ids]), v=as_slice([model.idx_vs[i] for i in ids]))

    @classmethod
    def for_mujoco(cls, model: mujoco.MjModel) -> JointMap:
        ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name) for name in digit.JOINT_NAMES]
        if min(ids) < 0:
            missing = [n for n, i in zip(digit.JOINT_NAMES, ids) if i < 0]
            raise ModelLoadError(f"MuJoCo model lacks joints {missing}")
        return cls(q=as_slice(model.jnt_qposadr[ids]), v=as_slice(model.jnt_dofadr[ids]))


def pinocchio_configuration(base_pos: np.ndarray, base_quat_wxyz: np.ndarray, q_joints: np.ndarray,
                            joint_map: JointMap) -> np.ndarray:
    """Pinocchio q from a base pose and joint positions in `JOINT_NAMES` order."""
    q = np.empty(7 + digit.NUM_JOINTS)
    q[:3] = base_pos
    w, x, y, z = np.asarray(base_quat_wxyz, dtype=float).tolist()
    q[3:7] = x, y, z, w  # pinocchio's order
    q[joint_map.q] = q_joints
    return q


def pinocchio_velocity(base_quat_wxyz: np.ndarray, v_world_base: np.ndarray, w_world_base: np.ndarray,
                       qd_joints: np.ndarray, joint_map: JointMap) -> np.ndarray:
    """Pinocchio v (base twist in the base frame) from world-frame base velocities."""
    quat = np.asarray(base_quat_wxyz, dtype=float).tolist()
    v = np.empty(6 + digit.NUM_JOINTS)
    v[:3] = rotate_inverse(quat, np.asarray(v_world_base, dtype=float))
    v[3:6] = rotate_inverse(quat, np.asarray(w_world_base, dtype=float))
    v[joint_map.v] = qd_joints
    return v
