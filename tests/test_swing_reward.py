"""PureRL's swing-foot term: the ALIP state from MuJoCo, the reference's ends, and what it rewards."""

import numpy as np
import pytest

from learn.rewards import base_orientation
from learn.swing_reward import SwingFootReference
from mbc import AlipController
from mbc.alip_state import alip_state_of
from mbc.geometry import yaw_of_quaternion
from mbc.rollout import perturbed_stand
from mbc.sim import DigitSim
from mbc.timing import GaitClock
from mbc.types import Command, JointCommand
from robots.digit import constants as digit


def _walk(sim: DigitSim, controller, seconds: float):
    state = perturbed_stand(sim, 0)
    controller.reset(state)
    for _ in range(int(seconds / sim.dt)):
        state = sim.step(controller.act(state, Command(0.5)))
    return state


def test_alip_state_from_mujoco_matches_the_controllers_pinocchio_one():  # DigitSim.momentum_about
    sim, controller = DigitSim("flat", seed=0), AlipController.for_digit()
    state = _walk(sim, controller, 1.3)
    controller.act(state, Command(0.5))  # its diagnostics of this very state
    seen = controller.last_diagnostics
    mujoco_alip = alip_state_of(*sim.momentum_about(seen.stance_sole_world), yaw_of_quaternion(state.base_quat))
    np.testing.assert_allclose(mujoco_alip.x, seen.alip.x, atol=0.01)  # the two models' CoMs within a centimetre
    np.testing.assert_allclose(mujoco_alip.L, seen.alip.L, atol=0.03 * np.abs(seen.alip.L).max() + 0.5)


def test_the_reference_starts_at_the_liftoff_and_ends_on_the_landing_point():
    sim = DigitSim("flat", seed=0)
    state = sim.reset()
    reference, clock = SwingFootReference(sim), GaitClock()
    clock.reset(state.time, stance=0, phase=0.0)
    command = np.array([0.4, 0.0, 0.0])
    liftoff = sim.sole_position(clock.swing)
    np.testing.assert_allclose(reference.reference(clock, command, state.base_quat), liftoff, atol=1e-12)
    clock.reset(state.time, stance=0, phase=1.0)  # the same step (no touchdown counted), at its end
    clock.touchdowns = 0
    landing = reference.landing(clock, command, 0.0)
    np.testing.assert_allclose(reference.reference(clock, command, state.base_quat), landing, atol=1e-9)
    assert landing[1] < sim.sole_position(0)[1]  # the right foot lands right of the left stance foot
    clock.reset(state.time, stance=0, phase=-0.2)
    assert reference.reference(clock, command, state.base_quat) is None  # the weight shift: no swing
    assert reference.reward(clock, command, state.base_quat) == 0.0


def test_the_mbc_walking_scores_high_and_a_stiff_stand_low():
    sim, controller = DigitSim("flat", seed=0), AlipController.for_digit()
    reference = SwingFootReference(sim)
    state = _walk(sim, controller, 1.0)
    scores = []
    for _ in range(int(2.0 / sim.dt)):  # the controller's own clock: the step it is taking
        state = sim.step(controller.act(state, Command(0.5)))
        scores.append(reference.reward(controller.clock, np.array([0.5, 0.0, 0.0]), state.base_quat))
    stand_sim = DigitSim("flat", seed=0)
    stand_state, clock = stand_sim.reset(), GaitClock()
    clock.reset(stand_state.time, stance=0, phase=0.0)
    standing = SwingFootReference(stand_sim)
    hold = JointCommand.hold(digit.Q_STAND)
    stand_scores = []
    for _ in range(int(2.0 / sim.dt)):
        stand_state = stand_sim.step(hold)
        clock.update(stand_state.time, np.array([False, False]))  # a clock that steps, a robot that does not
        stand_scores.append(standing.reward(clock, np.array([0.5, 0.0, 0.0]), stand_state.base_quat))
    assert np.mean(scores) > 0.6 > 0.4 > np.mean(stand_scores)


@pytest.mark.parametrize("tilt", [0.0, 0.1, 0.3])
def test_base_orientation_is_sin_squared_of_the_tilt(tilt):
    quat = np.array([np.cos(tilt / 2), np.sin(tilt / 2) * 0.6, np.sin(tilt / 2) * 0.8, 0.0])
    assert base_orientation(quat) == pytest.approx(np.sin(tilt) ** 2)
