"""Digit v3 open-chain model: the one source of its numbers.

The model is the open-chain equivalent of Agility Robotics' Digit v3: 6 actuated joints per leg
(hip roll, hip yaw, hip pitch, knee, ankle pitch, ankle roll), arms locked and lumped into the
pelvis, loops and springs removed (their masses folded into the neighbouring links), box feet.
At q = 0 the robot is in Digit's nominal stand and every joint axis is aligned with a pelvis axis.

Frames: pelvis x forward, y left, z up, origin at the height of the hip-roll axes. The right leg
mirrors the left in y (offsets and CoMs y -> -y, inertia products Ixy and Iyz negated); joint axes
keep their direction, so ranges of x- and z-axis joints are negated and swapped on the right.

Everything that needs the joint order (MuJoCo, pinocchio, placo, the policy) uses `JOINT_NAMES`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SIDES = ("left", "right")
LEG_JOINTS = ("hip_roll", "hip_yaw", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")
JOINT_NAMES = tuple(f"{side}_{joint}" for side in SIDES for joint in LEG_JOINTS)
"""The one joint order: left leg hip to ankle, then right leg."""
NUM_JOINTS = len(JOINT_NAMES)

BASE_LINK = "pelvis"
FOOT_LINKS = ("left_foot", "right_foot")
SOLE_FRAMES = ("left_sole", "right_sole")
"""Sole frames: centre of the foot's contact face, axes aligned with the foot link."""


@dataclass(frozen=True)
class LegLink:
    """One link of the left leg and the joint that moves it (pelvis-aligned axes at q = 0)."""

    joint: str
    link: str
    axis: tuple[float, float, float]
    offset_m: tuple[float, float, float]
    """Parent joint origin -> this joint origin."""
    mass_kg: float
    com_m: tuple[float, float, float]
    """Link CoM relative to this joint's origin."""
    inertia: tuple[float, float, float, float, float, float]
    """Inertia about the CoM: Ixx Iyy Izz Ixy Ixz Iyz [kg m^2]."""


PELVIS_MASS_KG = 22.21184
"""Torso 15.028 kg plus both arms locked at the stand pose."""
PELVIS_COM_M = (-0.0178, 0.00014, 0.2547)
PELVIS_INERTIA = (0.940125, 0.554918, 0.519149, -0.00015, 0.010407, 0.00005)

LEFT_LEG = (
    LegLink("hip_roll", "hip_roll_link", (1, 0, 0), (-0.0010, 0.0910, 0.0), 0.91509,
            (-0.03143, 0.00033, -0.00195), (0.000766, 0.001148, 0.001017, 0.000005, -0.000013, 0.000003)),
    LegLink("hip_yaw", "hip_yaw_link", (0, 0, 1), (-0.0440, 0.00213, -0.05045), 0.81875,
            (0.00004, -0.00017, -0.04208), (0.001627, 0.001931, 0.000768, -0.000007, 0.000003, -0.000004)),
    LegLink("hip_pitch", "thigh_link", (0, 1, 0), (-0.00011, 0.00687, -0.06777), 8.54530,
            (0.02565, 0.03108, -0.09532), (0.112667, 0.143957, 0.049635, -0.002695, -0.020629, -0.009525)),
    LegLink("knee", "shank_link", (0, 1, 0), (-0.22014, 0.01112, -0.50871), 2.00249,
            (0.04358, 0.00417, -0.08748), (0.017786, 0.029739, 0.013534, -0.000873, 0.013580, 0.001058)),
    LegLink("ankle_pitch", "ankle_link", (0, 1, 0), (0.27059, 0.02019, -0.30731), 0.04388,
            (-0.00012, 0.0, -0.00007), (0.000006, 0.000004, 0.000007, 0.0, -0.000001, 0.0)),
    LegLink("ankle_roll", "foot_link", (1, 0, 0), (0.0, 0.0, 0.0), 0.53128,
            (-0.00699, -0.00023, -0.03575), (0.000544, 0.001870, 0.001915, 0.0, -0.000016, 0.0)),
)

FOOT_SIZE_M = (0.235, 0.080, 0.023)
"""Foot contact box, full size x (length), y (width), z (thickness)."""
FOOT_BOX_CENTER_M = (-0.00155, 0.0, -0.05057)
"""Foot box centre relative to the ankle (left; y mirrors)."""
SOLE_BELOW_ANKLE_M = 0.06207
SOLE_FRAME_M = (FOOT_BOX_CENTER_M[0], 0.0, -SOLE_BELOW_ANKLE_M)

# Per leg joint, in LEG_JOINTS order (left leg; see `joint_limits` for both legs).
_LEFT_RANGE_DEG = ((-40.9, 79.1), (-41.5, 38.5), (-71.0, 79.0), (-85.0, 45.0), (-60.0, 60.0), (-30.0, 30.0))
_TORQUE_LIMIT_NM = (113.0, 79.2, 216.9, 231.3, 77.7, 25.1)
_SPEED_LIMIT_RADPS = (4.58, 7.33, 8.51, 7.5, 11.5, 11.5)
_ARMATURE_KGM2 = (0.1738, 0.0679, 0.1205, 0.154, 0.066, 0.0066)
_DAMPING_NMS = (1.0, 1.0, 1.0, 1.0, 1.0, 1.0)
_FRICTIONLOSS_NM = (1.0, 1.0, 0.5, 0.5, 1.0, 1.0)

# The joint PD gains of the action space: what every JointCommand means, on every simulator
# (tau = Kp (q_des - q) + Kd (qd_des - qd) + tau_ff at the physics rate). They are the stiffness a real
# Digit runs, not a simulator convenience (docs/design.md, "Actuation"): roadrunner's sim-to-real motor
# gains (kp 80 / 80 / 110 / 140 / 40 / 40 on hip roll, yaw, pitch, knee, toe A, toe B), seen through the
# closed chain's motor Jacobian at the stand, are joint stiffnesses of 80 / 80 / 110 / 161 / 74 / 34 N m/rad;
# the Isaac Lab Digit of the paper's lab runs 100 (hip roll, yaw) and 200 (hip pitch, knee). Hips and knee
# take the Isaac Lab values (at most 1.8x roadrunner's), the ankle half of roadrunner's: the ALIP's stance
# ankle is nearly passive, and the swing foot needs little.
_KP = (100.0, 100.0, 200.0, 200.0, 40.0, 20.0)
_KD = (10.0, 8.0, 10.0, 10.0, 3.0, 1.5)

TOTAL_MASS_KG = PELVIS_MASS_KG + 2 * sum(link.mass_kg for link in LEFT_LEG)
PELVIS_HEIGHT_STAND_M = 0.99631
"""Pelvis origin above flat ground at the nominal stand (q = 0, soles flat)."""
COM_HEIGHT_STAND_M = 0.95205
"""Whole-body CoM above flat ground at the nominal stand."""
Q_STAND = np.zeros(NUM_JOINTS)
"""Nominal stand joint positions [rad] (Digit's `reset_qpos`)."""


def mirror_y(v: tuple[float, ...]) -> tuple[float, ...]:
    """Mirror a 3-vector in the sagittal plane (y -> -y)."""
    return (v[0], -v[1], v[2])


def mirror_inertia(inertia: tuple[float, ...]) -> tuple[float, ...]:
    """Mirror an inertia (Ixx Iyy Izz Ixy Ixz Iyz) in the sagittal plane: Ixy and Iyz change sign."""
    ixx, iyy, izz, ixy, ixz, iyz = inertia
    return (ixx, iyy, izz, -ixy, ixz, -iyz)


def leg_links(side: str) -> tuple[LegLink, ...]:
    """The six links of one leg, mirrored for the right side."""
    if side not in SIDES:
        raise ValueError(f"unknown side {side!r}; valid: {SIDES}")
    if side == "left":
        return LEFT_LEG
    return tuple(
        LegLink(link.joint, link.link, link.axis, mirror_y(link.offset_m), link.mass_kg,
                mirror_y(link.com_m), mirror_inertia(link.inertia))
        for link in LEFT_LEG
    )


def _right_range(lo: float, hi: float, axis: tuple[float, float, float]) -> tuple[float, float]:
    """Rotations about x and z are mirrored by the sagittal plane; about y they are not."""
    return (-hi, -lo) if axis[1] == 0 else (lo, hi)


def _both_legs(values: tuple[float, ...]) -> np.ndarray:
    return np.array(values + values, dtype=float)


Q_MIN_RAD = np.deg2rad([lo for lo, _ in _LEFT_RANGE_DEG]
                       + [_right_range(lo, hi, link.axis)[0] for (lo, hi), link in zip(_LEFT_RANGE_DEG, LEFT_LEG)])
Q_MAX_RAD = np.deg2rad([hi for _, hi in _LEFT_RANGE_DEG]
                       + [_right_range(lo, hi, link.axis)[1] for (lo, hi), link in zip(_LEFT_RANGE_DEG, LEFT_LEG)])
TORQUE_LIMIT_NM = _both_legs(_TORQUE_LIMIT_NM)
SPEED_LIMIT_RADPS = _both_legs(_SPEED_LIMIT_RADPS)
ARMATURE_KGM2 = _both_legs(_ARMATURE_KGM2)
DAMPING_NMS = _both_legs(_DAMPING_NMS)
FRICTIONLOSS_NM = _both_legs(_FRICTIONLOSS_NM)
KP = _both_legs(_KP)
"""(12,) joint stiffness of the action space [N m / rad]: the one definition (see the note above `_KP`)."""
KD = _both_legs(_KD)
"""(12,) joint damping of the action space [N m s / rad]."""

for _array in (Q_MIN_RAD, Q_MAX_RAD, TORQUE_LIMIT_NM, SPEED_LIMIT_RADPS, ARMATURE_KGM2, DAMPING_NMS,
               FRICTIONLOSS_NM, KP, KD, Q_STAND):
    _array.setflags(write=False)
