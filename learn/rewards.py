"""Reward terms of the paper's Table (one small function per term) and their weighted sum.

    lin_vel_tracking   exp(-|v_xy - v_xy_cmd|^2 / delta_xy)     weight  1.2
    ang_vel_tracking   exp(-(w_z - w_z_cmd)^2 / delta_w)         weight  1.1
    torque             |tau|^2                                  weight -4e-6
    base_motion        |w_xy|^2                                 weight -0.6

Velocities are in the heading frame (linear) and the base frame (angular), as the command is. An option
beyond the paper's table (`EnvConfig.mean_vel_tracking_weight`, 0 by default):

    mean_vel_tracking  exp(-|e_xy|^2 / delta_mean), e_xy the heading-frame velocity error to the command
                       averaged over a gait cycle (`learn.mean_velocity`)

The instantaneous term cannot see a steady drift of a few cm/s under the sway of walking: with sway s and bias b,
exp(-(s^2 + b^2) / delta) loses about b^2 / delta, 2% of the term at b = 0.07 m/s and the paper's delta = 0.25,
where the gait-averaged error at delta_mean = 0.01 loses 39% (docs/design.md, "drift on flat ground").
PureRL (`PURERL_WEIGHTS`, the paper's baseline: a reward like Radosavovic et al.'s with an ALIP swing-foot
trajectory, feet air time and second-order smoothness) adds:

    feet_air_time        sum over touchdowns of (air time - 0.3 s) (legged_gym's form)   weight  1.0
    action_smoothness    |a_t - 2 a_{t-1} + a_{t-2}|^2                                 weight -0.01
    swing_foot_tracking  exp(-|p_swing - p_ref|^2 / 0.01) (`learn.swing_reward`)       weight  0.5
    vertical_velocity    v_z^2 of the base [(m/s)^2]                                   weight -2.0
    base_orientation     |g_xy|^2, the gravity's direction in the base frame, horizontal weight -1.0
    contact_schedule     mean over feet of (1 if its contact is the gait clock's, else -0.3)  weight  1.0

The contact schedule (Humanoid-Gym's `feet_contact_number`) is the term that pays stepping over standing: the
gait clock (`mbc.timing.GaitClock`) has one foot in stance and the other in swing, both down only in the weight
shift, so a robot that stands on both feet scores (1 - 0.3) / 2 = 0.35 of it and one that steps to the clock 1.
The other stepping terms barely tell the two apart: the swing term gives a stand 0.67-0.75 of its 1 (the clock
ends a step at phase 0.6 when it finds the swing foot down) and feet air time about 0 for a 0.35 s step. At 3-5 M
steps PureRL still learns to stand with it (docs/design.md, "PureRL's reward").

and floors its weighted sum at `PURERL_REWARD_FLOOR` = 0 per tick (legged_gym's `only_positive_rewards`): from
scratch the penalties of a collapsing robot outweigh the tracking terms (a zero action, which asks for no torque,
falls in 0.3 s at about -2.8 per tick), so unfloored, ending an episode sooner pays and PPO learns to fall faster.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

PAPER_WEIGHTS = {"lin_vel_tracking": 1.2, "ang_vel_tracking": 1.1, "torque": -4e-6, "base_motion": -0.6}
PURERL_WEIGHTS = PAPER_WEIGHTS | {"feet_air_time": 1.0, "action_smoothness": -0.01, "swing_foot_tracking": 0.5,
                                  "vertical_velocity": -2.0, "base_orientation": -1.0,
                                  "contact_schedule": 1.0}
PURERL_REWARD_FLOOR = 0.0
AIR_TIME_TARGET_S = 0.3
CONTACT_MISMATCH_SCORE = -0.3


def lin_vel_tracking(v_xy_heading: np.ndarray, v_xy_command: np.ndarray, sigma: float) -> float:
    """exp(-|v_xy - v_xy_cmd|^2 / sigma), velocities in the heading frame [m/s]."""
    error = np.asarray(v_xy_heading, float) - np.asarray(v_xy_command, float)
    return float(np.exp(-float(error @ error) / sigma))


def ang_vel_tracking(yaw_rate: float, yaw_rate_command: float, sigma: float) -> float:
    """exp(-(w_z - w_z_cmd)^2 / sigma) [rad/s]."""
    return float(np.exp(-((yaw_rate - yaw_rate_command) ** 2) / sigma))


def torque(tau: np.ndarray) -> float:
    """|tau|^2 over the leg joints [(N m)^2]."""
    tau = np.asarray(tau, float)
    return float(tau @ tau)


def base_motion(angvel_base: np.ndarray) -> float:
    """|w_xy|^2: roll and pitch rates of the base [(rad/s)^2]."""
    return float(angvel_base[0] ** 2 + angvel_base[1] ** 2)


def feet_air_time(air_time_s: np.ndarray, touchdown: np.ndarray, target_s: float = AIR_TIME_TARGET_S) -> float:
    """sum over feet touching down this tick of (air time - target) [s]."""
    return float(np.sum((np.asarray(air_time_s) - target_s) * np.asarray(touchdown, bool)))


def action_smoothness(action: np.ndarray, previous: np.ndarray, before_previous: np.ndarray) -> float:
    """|a_t - 2 a_{t-1} + a_{t-2}|^2."""
    second = np.asarray(action) - 2.0 * np.asarray(previous) + np.asarray(before_previous)
    return float(second @ second)


def contact_schedule(contact: Sequence[bool], scheduled: Sequence[bool]) -> float:
    """Mean over the feet of 1 where the contact flag is the scheduled one, else `CONTACT_MISMATCH_SCORE`."""
    scores = [1.0 if bool(c) == bool(s) else CONTACT_MISMATCH_SCORE for c, s in zip(contact, scheduled, strict=True)]
    return sum(scores) / len(scores)


def vertical_velocity(v_z: float) -> float:
    """v_z^2 of the base [(m/s)^2]."""
    return float(v_z * v_z)


def cos_tilt(quat_wxyz: np.ndarray) -> float:
    """Cosine of the angle between the base z axis and the world vertical: 1 - 2 (x^2 + y^2) for the unit
    quaternion (w, x, y, z)."""
    _, x, y, _ = np.asarray(quat_wxyz, float).tolist()
    return 1.0 - 2.0 * (x * x + y * y)


def base_orientation(quat_wxyz: np.ndarray) -> float:
    """|g_xy|^2 = sin^2(tilt) = 1 - cos^2(tilt): the horizontal part of the unit gravity direction in the base frame."""
    return 1.0 - cos_tilt(quat_wxyz) ** 2


@dataclass(frozen=True)
class RewardInputs:
    """What the reward terms read at one tick."""

    v_xy_heading: np.ndarray
    """(2,) base velocity, heading frame [m/s]."""
    angvel_base: np.ndarray
    """(3,) base angular velocity, base frame [rad/s]."""
    yaw_rate: float
    """World-frame yaw rate [rad/s]."""
    command: np.ndarray
    """(3,) vx, vy, yaw rate."""
    tau: np.ndarray
    """(12,) applied joint torques [N m]."""


def reward_terms(inputs: RewardInputs, lin_sigma: float, ang_sigma: float) -> dict[str, float]:
    """Each term's unweighted value."""
    return {"lin_vel_tracking": lin_vel_tracking(inputs.v_xy_heading, inputs.command[:2], lin_sigma),
            "ang_vel_tracking": ang_vel_tracking(inputs.yaw_rate, inputs.command[2], ang_sigma),
            "torque": torque(inputs.tau), "base_motion": base_motion(inputs.angvel_base)}


def total_reward(terms: dict[str, float], weights: dict[str, float] = PAPER_WEIGHTS, floor: float = -np.inf) -> float:
    """max(floor, sum_k w_k r_k) over the weighted terms."""
    return max(floor, float(sum(weights[name] * terms[name] for name in weights)))
