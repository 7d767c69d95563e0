"""Angular momentum about the contact point from the full robot, and the ALIP state from it."""

import mujoco
import numpy as np
import pytest

from mbc.alip_state import alip_state
from mbc.geometry import yaw_rotation
from mbc.pin_robot import PinRobot
from mbc.sim import DigitSim
from mbc.types import JointCommand
from robots.digit import constants as digit


@pytest.fixture(scope="module")
def robot():
    return PinRobot()


def test_rate_of_angular_momentum_equals_gravity_moment(robot, rng):
    """In flight (no contacts) dL_p/dt = (c - p) x m g about any fixed point p: central differences."""
    sim = DigitSim()
    state = sim.reset()
    sim.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    sim.set_gains(np.zeros(12), np.zeros(12))
    state.base_linvel, state.base_angvel, state.qd = rng.normal(size=3), rng.normal(size=3), rng.normal(size=12)
    sim.set_state(state)
    point = np.array([0.3, -0.2, 0.05])
    momenta, moments = [], []
    for _ in range(3):
        robot.update(sim.state())
        momenta.append(robot.angular_momentum_about(point))
        moments.append(np.cross(robot.com - point, robot.mass * sim.model.opt.gravity))
        sim.step(JointCommand.hold(np.zeros(12)))
    rate = (momenta[2] - momenta[0]) / (2 * sim.dt)
    np.testing.assert_allclose(rate, moments[1], rtol=2e-3, atol=0.05)
    assert np.linalg.norm(moments[1]) > 10  # the check is not vacuous


def test_point_mass_motion_gives_m_z_xdot(robot):
    """Pure translation: L about the ground point below the CoM is m z v in both pendulum axes."""
    sim = DigitSim()
    state = sim.reset()
    state.base_linvel = np.array([0.4, -0.2, 0.0])
    robot.update(state)
    contact = np.r_[robot.com[:2], 0.0]
    alip = alip_state(robot, contact, yaw=0.0)
    np.testing.assert_allclose(alip.x, 0.0, atol=1e-12)
    np.testing.assert_allclose(alip.L, digit.TOTAL_MASS_KG * robot.com[2] * np.array([0.4, -0.2]), rtol=1e-12)
    assert alip.com_height_above_contact_m == pytest.approx(digit.COM_HEIGHT_STAND_M, abs=3e-3)


def test_heading_frame_rotates_with_yaw(robot):
    sim = DigitSim()
    state = sim.reset()
    state.base_linvel = np.array([0.0, 0.5, 0.0])  # world +y
    robot.update(state)
    alip = alip_state(robot, np.r_[robot.com[:2] - [0.0, 0.1], 0.0], yaw=np.pi / 2)  # facing +y
    np.testing.assert_allclose(alip.x, [0.1, 0.0], atol=1e-12)  # CoM ahead of the contact
    assert alip.L[0] == pytest.approx(digit.TOTAL_MASS_KG * robot.com[2] * 0.5)
    assert alip.L[1] == pytest.approx(0.0, abs=1e-9)


def test_alip_state_is_the_heading_frame_view_of_the_momentum_about_the_contact(robot, rng):
    """x, L, z' in the heading frame against the world-frame quantities rotated by a matrix."""
    state = DigitSim().reset()
    state.base_linvel, state.base_angvel, state.qd = rng.normal(size=3), rng.normal(size=3), rng.normal(size=12)
    robot.update(state)
    for _ in range(5):
        yaw, point = rng.uniform(-np.pi, np.pi), rng.normal(size=3) * 0.3
        to_heading = yaw_rotation(yaw).T
        alip = alip_state(robot, point, yaw)
        momentum = to_heading @ robot.angular_momentum_about(point)
        np.testing.assert_allclose(alip.x, (to_heading @ (robot.com - point))[:2], atol=1e-12)
        np.testing.assert_allclose(alip.L, [momentum[1], -momentum[0]], atol=1e-10)
        np.testing.assert_allclose(alip.com_velocity, to_heading @ robot.com_velocity, atol=1e-12)
        assert alip.com_height_above_contact_m == pytest.approx(robot.com[2] - point[2], abs=1e-12)
