"""Digit v3 closed-chain model: the one source of its numbers (`../shared/digit/FACTS.md`, section 2).

Unlike the open chain of `constants.py`, this is Digit's real leg: the achilles rod and the two toe
rods are ball-jointed bodies closed onto the heel spring and the toe by `connect` constraints; the
shin (knee leaf spring) and the heel spring are stiff passive hinges; the tarsus, toe pitch and toe
roll are passive; six motors per leg (hip roll, yaw, pitch, knee, toe A, toe B) drive it through
their gears. The arms are locked at the stand pose, as in the open chain, but kept as bodies.

Frames are Digit's: each body's pose in its parent is `pos` and intrinsic x-y-z Euler angles
[deg]; every hinge turns about its body's z axis (hip pitch and shoulder pitch about -z). The right
side mirrors the left: pos y, Euler x and z, CoM y and the inertia products Ixy and Iyz change sign,
hinge axes stay, so a mirror-symmetric motion has opposite angles on the two sides.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

TIMESTEP_S = 0.0005
"""Physics step of the facts (Newton solver, 50 iterations)."""
SOLVER_ITERATIONS = 50
GRAVITY_MPS2 = 9.80665
EQUALITY_SOLREF = (0.001, 1.1)
EQUALITY_SOLIMP = (0.9, 0.95, 0.001, 0.1, 2.0)
JOINT_SOLREFLIMIT = (0.001, 1.0)
TORQUE_DELAY_STEPS = 6
"""Motor torque delay: 6 physics steps of 0.5 ms = 3 ms (roadrunner's sim-to-real setting)."""

TORSO = "torso"


@dataclass(frozen=True)
class Body:
    """One body of the left leg or arm, the joint that moves it, and its inertial data."""

    name: str
    parent: str
    pos_m: tuple[float, float, float]
    euler_deg: tuple[float, float, float]
    mass_kg: float
    com_m: tuple[float, float, float]
    inertia: tuple[float, float, float, float, float, float]
    """Ixx Iyy Izz Ixy Ixz Iyz about the CoM, body frame [kg m^2]."""
    joint: str
    """'hinge', '-hinge' (about -z), 'ball' or 'locked'."""
    range_deg: tuple[float, float] | None = None
    stiffness_nm_per_rad: float = 0.0
    damping_nms: float = 0.0
    frictionloss_nm: float = 0.0
    armature_kgm2: float = 0.0
    stand_deg: float = 0.0
    """Angle at Digit's nominal stand (`reset_qpos`; locked joints are welded there)."""


TORSO_MASS_KG = 15.028392
TORSO_COM_M = (0.001636612541, 0.0002001180789, 0.2593064529)
TORSO_INERTIA = (0.3759052548, 0.3441935, 0.09873232746, -8.776732849e-05, 0.008498611229, 6.621611757e-05)
TORSO_HEIGHT_M = 1.01
"""Torso origin above the world origin in the facts' model."""

LEFT_LEG = (
    Body("hip_roll", TORSO, (-0.001, 0.091, 0), (21.49994484, -90, 0), 0.915088, (-0.001967, 0.000244, 0.031435),
         (0.001017, 0.001148, 0.000766, -3e-06, 1.3e-05, -4e-06), "hinge", (-60, 60), 0, 1, 1, 0.173823936, 19.081),
    Body("hip_yaw", "hip_roll", (-0.0505, 0, 0.044), (0, -90, 0), 0.818753, (1e-05, -0.001945, 0.042033),
         (0.001627, 0.001929, 0.00077, -1e-06, 2e-06, 5.3e-05), "hinge", (-40, 40), 0, 1, 1, 0.067899975, -1.525),
    Body("hip_pitch", "hip_yaw", (0, 0.004, 0.068), (90, -2.86e-14, 134.9999776), 6.244279,
         (0.060537, 0.000521, -0.038857), (0.011533, 0.033345, 0.033958, -0.000171, 0.000148, 0.000178),
         "-hinge", (-60, 90), 0, 1, 0.5, 0.1204731904, 11.022),
    Body("achilles_rod", "hip_pitch", (0, 0, 0.046), (4.089984946, 0.05002908482, -82.27004088), 0.178148,
         (0.2506, 0, 0), (3e-06, 0.004501, 0.004501, 0, 0, 0), "ball", None, 0, 0.01),
    Body("knee", "hip_pitch", (0.12, 0, 0.0045), (0, 0, -90), 1.227077, (0.045641, 0.042154, 0.001657),
         (0.002643, 0.005098, 0.007019, -0.001832, 6.6e-05, 4.5e-05), "hinge", (-80, 58.4), 0, 1, 0.5,
         0.1204731904, 13.119),
    Body("shin", "knee", (0.060677, 0.047406, 0), (0, 0, 0), 0.895793, (0.174265, 0.010265, 0.00107),
         (0.001128, 0.022492, 0.022793, 0.001098, 0.000196, -3e-06), "hinge", None, 6000.0, 0, 0, 0, 0.085),
    Body("tarsus", "shin", (0.434759, 0.02, 0), (0, 0, 102.9999562), 1.322865, (0.100777, -0.029183, 0.000678),
         (0.000932, 0.016409, 0.016501, 0.00061, 0.000102, 9e-06), "hinge", (-50.3, 71.6), 0, 0.1, 0, 0, -13.261),
    Body("heel_spring", "tarsus", (-0.01766, -0.029456, 0.00104), (4.470028555, 0.3199786449, 155.799968), 0.230018,
         (0.049086, 0.004739, -4.5e-05), (5.5e-05, 0.00074, 0.000701, 1.5e-05, 1e-06, 0), "hinge", (-6, 6),
         4375.0, 0, 0, 0, 0.026),
    Body("toe_a", "tarsus", (0.059, -0.034, -0.0276), (180, -7.0e-15, 88.9599851), 0.139557,
         (0.005161, 1e-06, -0.002248), (2.9e-05, 5.8e-05, 7.4e-05, 0, -4e-06, 0), "hinge", (-46.2755, 44.9815), 0, 1, 1,
         0.036089475, -0.743),
    Body("toe_a_rod", "toe_a", (0.057, 0, -0.008), (0.3399877019, 2.140028166, -88.44995297), 0.090983,
         (0.171071, 0, 0), (1e-06, 0.001182, 0.001182, 0, 0, 0), "ball", None, 0, 0.01),
    Body("toe_b", "tarsus", (0.111, -0.034, 0.0276), (0, 0, -88.9599851), 0.139557, (0.005161, 1e-06, -0.002248),
         (2.9e-05, 5.8e-05, 7.4e-05, 0, -4e-06, 0), "hinge", (-45.8918, 45.5476), 0, 1, 1, 0.036089475, -1.168),
    Body("toe_b_rod", "toe_b", (0.057, 0, -0.008), (-0.220057762, -3.079997902, 88.34004019), 0.079507,
         (0.142991, 0, 0), (1e-06, 0.000768, 0.000768, 0, 0, 0), "ball", None, 0, 0.01),
    Body("toe_pitch", "tarsus", (0.408, -0.04, 0), (0, 0, 71.75004157), 0.043881, (-0.000141, 2e-06, 3e-06),
         (5e-06, 8e-06, 4e-06, 0, 0, 0), "hinge", (-44, 34), 0, 0.1, 0, 0, -0.202),
    Body("toe_roll", "toe_pitch", (0, 0, 0), (0, 90, 0), 0.531283, (9e-06, -0.028084, -0.023204),
         (0.00187, 0.001616, 0.000843, 0, 0, 0.000566), "hinge", (-37, 33), 0, 0.1, 0, 0, -3.180),
)
"""Left leg, parents before children."""

LEFT_ARM = (
    Body("shoulder_roll", TORSO, (-0.001, 0.12, 0.4), (-9.999933098, -90, 0), 0.535396, (-0.000819, -0.003158, 0.023405),
         (0.000704, 0.00075, 0.000298, 1.4e-05, 1.2e-05, 3.5e-05), "locked", stand_deg=-6.047),
    Body("shoulder_pitch", "shoulder_roll", (-0.00317, -0.011055, 0.0555), (89.99999034, -16.0000415, -44.99997193),
         1.440357, (-4.2e-05, -0.061882, -0.073788), (0.006761, 0.002087, 0.005778, -6e-06, -3e-06, -0.002046),
         "-locked", stand_deg=51.271),
    Body("shoulder_yaw", "shoulder_pitch", (0, -0.165, -0.1), (90, 0, 0), 1.065387, (-3e-05, 0.001937, 0.11407),
         (0.006967, 0.007003, 0.000673, -1e-06, -1e-06, -1.5e-05), "locked", stand_deg=-0.495),
    Body("elbow", "shoulder_yaw", (0, -0.0385, 0.185), (90, -3.2e-15, 22.50004688), 0.550582,
         (0.107996, 0.000521, -0.017765), (0.000476, 0.009564, 0.009437, -2.9e-05, 0.001403, 9e-06), "locked",
         stand_deg=19.754),
)

RIGHT_RANGE_DEG = {"hip_roll": (-60, 60), "hip_yaw": (-40, 40), "hip_pitch": (-90, 60), "knee": (-58.4, 80),
                   "tarsus": (-71.6, 50.3), "heel_spring": (-6, 6), "toe_a": (-44.9815, 46.2755),
                   "toe_b": (-45.5476, 45.8918), "toe_pitch": (-34, 44), "toe_roll": (-33, 37)}


@dataclass(frozen=True)
class Connect:
    """A `connect` constraint: `anchor_m` in `body1`'s frame meets the same point of `body2`'s at the
    model's zero configuration."""

    body1: str
    body2: str
    anchor_m: tuple[float, float, float]


LEFT_CONNECTS = (
    Connect("heel_spring", "achilles_rod", (0.113789, -0.011056, 0)),
    Connect("toe_roll", "toe_a_rod", (0.0179, -0.009551, -0.054164)),
    Connect("toe_roll", "toe_b_rod", (-0.0181, -0.009551, -0.054164)),
)


@dataclass(frozen=True)
class Motor:
    """A leg motor: gear ratio, joint torque limit (gear x motor torque) and no-load joint speed."""

    joint: str
    gear: float
    torque_limit_nm: float
    no_load_speed_radps: float
    kp: float
    """Roadrunner's sim-to-real PD gains at this joint [N m/rad], [N m s/rad]."""
    kd: float


LEG_MOTORS = (
    Motor("hip_roll", 80, 80 * 1.4125, 3500 * 2 * np.pi / 60 / 80, 80, 8),
    Motor("hip_yaw", 50, 50 * 1.5835307242, 3500 * 2 * np.pi / 60 / 50, 80, 8),
    Motor("hip_pitch", 16, 16 * 13.5579936387, 1300 * 2 * np.pi / 60 / 16, 110, 10),
    Motor("knee", 16, 16 * 14.4573093877, 1300 * 2 * np.pi / 60 / 16, 140, 12),
    Motor("toe_a", 50, 50 * 0.8395188473, 5500 * 2 * np.pi / 60 / 50, 40, 6),
    Motor("toe_b", 50, 50 * 0.8395188473, 5500 * 2 * np.pi / 60 / 50, 40, 6),
)
"""Per leg, in the order of the open chain's joints they drive (hip roll, yaw, pitch; knee; ankle)."""
MOTOR_NAMES = tuple(f"{side}_{m.joint}" for side in ("left", "right") for m in LEG_MOTORS)

FOOT_BOX_HALF_SIZE_M = (0.04, 0.1175, 0.0115)
FOOT_BOX_POS_M = (0.0, -0.0437, -0.0255)
FOOT_BOX_EULER_DEG = (-60.0, 0.0, 0.0)
"""The foot box in the toe-roll frame (left)."""
FOOT_FRICTION = (0.7, 0.01, 0.005)

TOTAL_MASS_KG = TORSO_MASS_KG + 2 * sum(b.mass_kg for b in LEFT_LEG + LEFT_ARM)


def mirror(body: Body) -> Body:
    """The right side's body: y, Euler x and z, CoM y, Ixy and Iyz negated; angles negated."""
    x, y, z = body.pos_m
    ex, ey, ez = body.euler_deg
    ixx, iyy, izz, ixy, ixz, iyz = body.inertia
    rng = RIGHT_RANGE_DEG.get(body.name, body.range_deg)
    return Body(body.name, body.parent, (x, -y, z), (-ex, ey, -ez), body.mass_kg,
                (body.com_m[0], -body.com_m[1], body.com_m[2]), (ixx, iyy, izz, -ixy, ixz, -iyz), body.joint, rng,
                body.stiffness_nm_per_rad, body.damping_nms, body.frictionloss_nm, body.armature_kgm2, -body.stand_deg)
