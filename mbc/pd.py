"""The inverse of the simulator's joint PD law, tau = kp (q_des - q) + kd (qd_des - qd): the position
targets that make the PD give a wanted torque, which is how the controller acts in the policy's action
space. In plain floats (12 values): numpy calls on 12-vectors cost microseconds each in a 200 Hz tick
(docs/design.md); the numpy form is in the docstring, and a test holds the function to it."""

from __future__ import annotations


def position_target_for_torque(tau: list[float], qd_des: list[float], q: list[float], qd: list[float],
                               kp: list[float], kd: list[float]) -> list[float]:
    """q_des = q + (tau - kd * (qd_des - qd)) / kp   (numpy form, element-wise) [rad]."""
    return [angle + (torque - d * (rate_target - rate)) / p
            for torque, rate_target, angle, rate, p, d in zip(tau, qd_des, q, qd, kp, kd)]
