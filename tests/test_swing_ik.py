"""Swing trajectories and whole-body IK."""

import numpy as np
import pytest

from mbc.assumptions import MAR_DELTA, mar_weight
from mbc.ik import IkTargets, WholeBodyIK
from mbc.pin_robot import PinRobot
from mbc.sim import DigitSim
from mbc.swing import SwingConfig, estimate_phase, min_jerk, swing_height, swing_reference


def test_min_jerk_blend_and_derivative():
    s = np.linspace(0, 1, 101)
    b, db = min_jerk(s)
    assert b[0] == 0 and b[-1] == 1 and np.all(np.diff(b) >= 0)
    numeric = np.gradient(b, s)
    np.testing.assert_allclose(db[1:-1], numeric[1:-1], atol=2e-3)


def test_vertical_profile_apex_landing_and_velocity():
    cfg, T = SwingConfig(clearance_m=0.1, apex_phase=0.5), 0.35
    assert swing_height(0.0, cfg, T)[0] == pytest.approx(0.0)
    assert swing_height(0.5, cfg, T) == pytest.approx((0.1, 0.0))
    assert swing_height(1.0, cfg, T) == pytest.approx((0.0, -cfg.late_descent_mps))
    s = np.linspace(0.01, 0.99, 99)
    heights = np.array([swing_height(x, cfg, T)[0] for x in s])
    velocities = np.array([swing_height(x, cfg, T)[1] for x in s])
    np.testing.assert_allclose(velocities[1:-1], np.gradient(heights, s * T)[1:-1], atol=5e-3)
    assert swing_height(1.2, cfg, T)[0] < 0  # late touchdown: keeps descending


def test_time_to_go_reaches_the_target_from_anywhere(rng):
    cfg, T, dt = SwingConfig(), 0.35, 0.005
    target = np.array([0.3, -0.2, 0.0])
    position = np.array([-0.1, -0.25, 0.0])
    for k in range(int(T / dt)):
        position, _ = swing_reference(position, target, k * dt / T, dt / T, T, cfg)
        if k == int(T / dt) // 2:
            target = target + [0.05, 0.02, 0.0]  # the target moves mid-swing
    np.testing.assert_allclose(position[:2], target[:2], atol=1e-9)


def test_ik_reaches_swing_target_keeps_stance_and_height():
    sim = DigitSim()
    state = sim.reset()
    robot = PinRobot()
    robot.update(state)
    ik = WholeBodyIK()
    right = robot.sole_position(1)
    left = robot.sole_position(0)
    com_z = left[2] + 0.94
    targets = IkTargets(stance=0, swing_position=right + [0.08, 0.0, 0.05], swing_velocity=np.zeros(3),
                        swing_yaw=0.0, ground_normal=np.array([0.0, 0.0, 1.0]), pelvis_yaw=0.0, com_z_world_m=com_z,
                        pelvis_xy=state.base_pos[:2],
                        pelvis_xy_velocity=np.zeros(2))
    q = robot.q
    for _ in range(5):  # a few ticks from the IK's own output converge onto the targets
        result = ik.solve(q, targets)
        q = ik.robot.state.q.copy()
    assert result.converged
    assert result.swing_error_m < 5e-3 and abs(result.com_height_error_m) < 5e-3
    np.testing.assert_allclose(ik.robot.get_T_world_frame("left_sole")[:3, 3], left, atol=1e-4)


def test_mar_weight():
    assert mar_weight(0.0) == pytest.approx(5.0)
    assert mar_weight(np.sqrt(MAR_DELTA)) == pytest.approx(5.0 / np.e)
    assert np.all(np.diff(mar_weight(np.linspace(0, 1, 10))) < 0)


def test_phase_estimate_inverts_the_profile():
    cfg, T = SwingConfig(), 0.35
    for s in (0.1, 0.3, 0.45, 0.6, 0.8, 0.95):
        height, velocity = swing_height(s, cfg, T)
        assert estimate_phase(height + cfg.landing_offset_m, velocity, cfg) == pytest.approx(s, abs=1e-6)
