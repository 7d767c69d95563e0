"""The walking task: observation layout, action space, reward terms, clocks, termination, bad input."""

import math

import numpy as np
import pytest

from learn.action import ACTION_DIM, ActionSpace
from learn.config import CommandSampling, EnvConfig, PushSampling
from learn.env import WalkEnv, parse_terrain, sample_command, tilt_of
from learn.observation import ObservationBuilder, ObservationLayout
from learn.rewards import PAPER_WEIGHTS, RewardInputs, ang_vel_tracking, base_motion, lin_vel_tracking, reward_terms, torque
from mbc.errors import ConfigError
from mbc.fuzz import random_joint_positions, random_quaternion_wxyz
from mbc.geometry import wrap_angle, yaw_of_quaternion
from mbc.types import JointCommand, RobotState

QUIET = EnvConfig(terrains=("flat",), pushes=PushSampling(probability=0.0))


def random_robot_state(rng: np.random.Generator) -> RobotState:
    """A finite state with random orientation, velocities and joints."""
    return RobotState(time=float(rng.uniform(0, 10)), base_pos=rng.normal(size=3), base_quat=random_quaternion_wxyz(rng),
                      base_linvel=rng.normal(size=3), base_angvel=rng.normal(size=3), q=random_joint_positions(rng),
                      qd=rng.normal(size=12), contact=np.array([True, False]))


def test_observation_layout_places_each_part_where_it_says(rng):
    layout = ObservationLayout(history_length=3)
    assert layout.size == 3 + 3 + 3 + 3 + 12 + 12 + 4 + 24 + 36 + 36
    builder = ObservationBuilder(3)
    first = random_robot_state(rng)
    first.contact = np.array([True, True])
    builder.reset(first)
    builder.observe(first, np.zeros(3))
    builder.record_action(np.arange(ACTION_DIM, dtype=float))
    second = first.copy()
    second.time += 0.005
    second.q = first.q + 0.1
    obs = builder.observe(second, np.array([0.3, -0.1, 0.2]))
    np.testing.assert_allclose(obs[layout.slice("command")], [0.3, -0.1, 0.2])
    np.testing.assert_allclose(obs[layout.slice("q")], second.q)
    np.testing.assert_allclose(obs[layout.slice("previous_action")], np.arange(ACTION_DIM))
    np.testing.assert_allclose(obs[layout.slice("q_history")][:12], first.q)  # most recent first
    w, x, y, z = second.base_quat / np.linalg.norm(second.base_quat)
    rotation = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                         [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                         [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    np.testing.assert_allclose(obs[layout.slice("projected_gravity")], rotation.T @ [0, 0, -1], atol=1e-9)
    np.testing.assert_allclose(obs[layout.slice("base_linvel")], rotation.T @ second.base_linvel, atol=1e-9)
    with pytest.raises(KeyError, match="parts"):
        layout.slice("camera")


def test_action_space_round_trips_and_means_torque(rng):
    space = ActionSpace()
    state = random_robot_state(rng)
    action = rng.normal(size=ACTION_DIM)
    command = space.to_command(action, state)
    np.testing.assert_allclose(space.from_command(command, state), action, atol=1e-12)
    # one action unit on the position part is one torque limit through the stiffness
    tau = space.kp * (command.q_des - state.q)
    np.testing.assert_allclose(tau, action[:12] * space.torque_scale, rtol=1e-12)
    # a feed-forward torque folds into the position term: the same PD torque
    with_ff = JointCommand(q_des=state.q, qd_des=state.qd, tau_ff=np.full(12, 5.0))
    np.testing.assert_allclose(space.from_command(with_ff, state)[:12] * space.torque_scale, 5.0)


def test_reward_terms_against_hand_computed_values():
    assert lin_vel_tracking(np.array([0.5, 0.1]), np.array([0.3, 0.0]), 0.25) == pytest.approx(math.exp(-0.05 / 0.25))
    assert ang_vel_tracking(0.2, -0.1, 0.25) == pytest.approx(math.exp(-0.09 / 0.25))
    assert torque(np.array([3.0, 4.0] + [0.0] * 10)) == pytest.approx(25.0)
    assert base_motion(np.array([0.3, -0.4, 7.0])) == pytest.approx(0.25)
    terms = reward_terms(RewardInputs(np.array([0.3, 0.0]), np.array([0.3, -0.4, 7.0]), -0.1, np.array([0.3, 0.0, -0.1]),
                                      np.full(12, 10.0)), 0.25, 0.25)
    total = sum(PAPER_WEIGHTS[k] * v for k, v in terms.items())
    assert total == pytest.approx(1.2 * 1.0 + 1.1 * 1.0 - 4e-6 * 1200.0 - 0.6 * 0.25)


def test_env_clock_agrees_with_the_expert_clock_while_the_expert_walks():
    env = WalkEnv(QUIET)
    env.reset(seed=3)
    env.command = np.array([0.3, 0.0, 0.0])
    env._next_command_s = math.inf
    touchdowns = 0
    for _ in range(600):
        action, valid = env.label()
        assert valid
        expert_clock, env_clock = env.expert.controller.clock, env.builder.clock
        assert env_clock.stance == expert_clock.stance
        assert env_clock.phase == pytest.approx(expert_clock.phase, abs=1e-9)
        step = env.step(action)
        assert not step.terminated
        touchdowns = env_clock.touchdowns
    assert touchdowns >= 6  # 3 s of walking at 0.35 s a step


def test_expert_says_whether_its_label_is_for_the_commanded_velocity():
    """Within range and after its ramp: followed; beyond its range, past its turning limit or mid-ramp: its
    action is for another command."""
    env = WalkEnv(QUIET)
    env.reset(seed=0)
    followed = []
    for command in ([0.3, 0.0, 0.0], [0.3, 0.0, 0.0], [1.4, 0.0, 0.0], [0.9, 0.0, 0.8], [0.3, 0.2, 0.0]):
        action, _ = env.expert.label(env.state, np.array(command))
        followed.append(env.expert.followed(np.array(command)))
        env.step(action)
    # the first command is followed at once; 1.4 m/s is beyond 1.0; 0.9 x 0.8 beyond 0.3 m/s^2; vy stepped by 0.2
    assert followed == [True, True, False, False, False]


def test_episode_terminates_on_a_fall_and_reports_monitors():
    env = WalkEnv(QUIET)
    env.reset(seed=0)
    limp = np.zeros(ACTION_DIM)
    limp[:12] = -0.5  # targets far below the joints: the legs give way
    for _ in range(400):
        step = env.step(limp)
        if step.terminated:
            break
    assert step.terminated and not step.truncated
    assert np.all(np.isfinite(env.monitors))


def test_the_heading_error_is_measured_from_the_commanded_heading():
    """psi_ref = psi_0 + sum(w_cmd dt); the expert turning on command stays near it, far from its first heading."""
    env = WalkEnv(QUIET)
    env.reset(seed=0)
    first_yaw = yaw_of_quaternion(env.state.base_quat)
    env.command = np.array([0.0, 0.0, 0.4])
    env.commanded_heading.update(first_yaw, env.state.time, 0.4)  # the command from the first tick on
    for _ in range(400):  # 2 s, before the command is first redrawn (after at least 2.5 s)
        action, _ = env.label()
        env.step(action)
    reference = env.commanded_heading.heading_rad
    assert reference == pytest.approx(first_yaw + 0.4 * env.episode_time_s)
    yaw = yaw_of_quaternion(env.state.base_quat)
    turned = wrap_angle(yaw - first_yaw)
    assert turned > 0.5
    assert abs(wrap_angle(yaw - reference)) <= env.largest_heading_error_rad < 0.5 * turned
    env.reset(seed=1)
    assert env.largest_heading_error_rad == 0.0


def test_episode_truncates_at_its_length():
    env = WalkEnv(EnvConfig(terrains=("flat",), episode_length_s=0.05, pushes=PushSampling(probability=0.0)))
    env.reset(seed=0)
    flags = []
    for _ in range(10):
        action, _ = env.label()
        flags.append(env.step(action).truncated)
    assert flags == [False] * 9 + [True]


def test_commands_are_drawn_within_their_ranges(rng):
    sampling = CommandSampling(standing_probability=0.2)
    commands = np.array([sample_command(rng, sampling) for _ in range(2000)])
    assert np.all(commands[:, 0] >= -0.5) and np.all(commands[:, 0] <= 1.0)
    assert np.all(np.abs(commands[:, 1]) <= 0.3) and np.all(np.abs(commands[:, 2]) <= 0.8)
    assert 0.15 < np.mean(np.all(commands == 0, axis=1)) < 0.25


def test_tilt_of_a_quaternion():
    angle = 0.3
    assert tilt_of(np.array([math.cos(angle / 2), math.sin(angle / 2), 0.0, 0.0])) == pytest.approx(angle)


def test_bad_terrain_and_config_values_give_clear_errors():
    assert parse_terrain("slope:angle_deg=5,length_m=4") == ("slope", {"angle_deg": 5.0, "length_m": 4.0})
    with pytest.raises(ConfigError, match="key=number"):
        parse_terrain("slope:angle_deg=steep")
    with pytest.raises(ConfigError, match="valid terrains"):
        WalkEnv(EnvConfig(terrains=("lava",)))
    with pytest.raises(ConfigError, match="low <= high"):
        CommandSampling(vx_mps=(1.0, -1.0))
    with pytest.raises(ConfigError, match="ang_vel_tracking_sigma must be positive"):
        EnvConfig(ang_vel_tracking_sigma=0.0)
    with pytest.raises(ConfigError, match="without an expert"):
        env = WalkEnv(QUIET, with_expert=False)
        env.reset(0)
        env.label()


def test_walking_off_a_bounded_terrain_ends_the_episode_without_a_fall():
    env = WalkEnv(EnvConfig(terrains=("uneven:amplitude=0.01,extent_m=1.0",), pushes=PushSampling(probability=0.0)))
    env.reset(seed=0)
    state = env.state.copy()
    state.base_pos = state.base_pos + np.array([3.0, 0.0, 0.0])  # beyond the 1 m heightfield: no ground below
    env.sim.set_state(state)
    env.state = env.sim.state()
    action, _ = env.label()
    step = env.step(action)
    assert step.truncated and not step.terminated


def test_purerl_terms_are_reported_and_weighted_when_on():
    import dataclasses

    from learn.rewards import PURERL_WEIGHTS

    env = WalkEnv(dataclasses.replace(QUIET, purerl_rewards=True), with_expert=True)
    env.reset(seed=3)
    swings, schedules = [], []
    for _ in range(300):  # the expert walks: past the weight shift, into steps
        action, _ = env.label()
        step = env.step(action)
        assert set(PURERL_WEIGHTS) <= set(step.reward_terms)
        assert step.reward == pytest.approx(max(0.0, sum(w * step.reward_terms[k] for k, w in PURERL_WEIGHTS.items())))
        swings.append(step.reward_terms["swing_foot_tracking"])
        schedules.append(step.reward_terms["contact_schedule"])
    assert 0.0 <= min(swings) and max(swings) <= 1.0 and np.mean(swings[-100:]) > 0.5  # the MBC follows its law
    assert np.mean(schedules[-100:]) > 0.9  # and steps to its clock
    plain = WalkEnv(QUIET, with_expert=False)
    plain.reset(seed=3)
    assert "swing_foot_tracking" not in plain.step(np.zeros(ACTION_DIM)).reward_terms


def test_the_contact_schedule_pays_stepping_to_the_clock_over_standing():
    from learn.rewards import CONTACT_MISMATCH_SCORE, contact_schedule

    left_stance = np.array([True, False])
    assert contact_schedule(left_stance, left_stance) == 1.0
    assert contact_schedule(np.array([True, True]), left_stance) == pytest.approx((1 + CONTACT_MISMATCH_SCORE) / 2)
    assert contact_schedule(np.array([False, True]), left_stance) == CONTACT_MISMATCH_SCORE
    assert contact_schedule(np.array([True, True]), np.array([True, True])) == 1.0  # the weight shift


def test_purerl_reward_is_floored_so_that_falling_sooner_does_not_pay():
    import dataclasses

    from learn.rewards import PURERL_WEIGHTS

    env = WalkEnv(dataclasses.replace(QUIET, purerl_rewards=True), with_expert=False)
    env.reset(seed=0)
    rewards, sums = [], []
    for _ in range(400):  # a zero action asks for no torque: Digit collapses
        step = env.step(np.zeros(ACTION_DIM))
        rewards.append(step.reward)
        sums.append(sum(w * step.reward_terms[k] for k, w in PURERL_WEIGHTS.items()))
        if step.terminated:
            break
    assert step.terminated and min(sums) < 0.0  # the penalties of the collapse outweigh the tracking terms
    assert min(rewards) >= 0.0 and rewards == pytest.approx([max(0.0, x) for x in sums])


def test_the_time_keeping_clock_ends_each_step_at_phase_one_whatever_the_feet_do():
    """A robot standing still: the MBC's clock finds the swing foot down and ends every step at phase 0.6; the
    'time' clock keeps the weight shift, the short first step and then 0.35 s steps."""
    from learn.observation import gait_timing

    standing = RobotState(time=0.0, base_pos=np.array([0, 0, 1.0]), base_quat=np.array([1.0, 0, 0, 0]),
                          base_linvel=np.zeros(3), base_angvel=np.zeros(3), q=np.zeros(12), qd=np.zeros(12),
                          contact=np.array([True, True]))
    phases, touchdowns = {}, {}
    for name in ("contact", "time"):
        builder = ObservationBuilder(0, gait_timing(name))
        builder.reset(standing)
        state, highest = standing.copy(), -1.0
        for _ in range(400):  # 2 s
            state.time += 0.005
            builder.observe(state, np.zeros(3))
            highest = max(highest, builder.clock.phase)
        phases[name], touchdowns[name] = highest, builder.clock.touchdowns
    timing = gait_timing("time")
    assert timing.early_touchdown_phase == timing.late_touchdown_phase == 1.0
    assert phases["contact"] < 0.61 and phases["time"] == pytest.approx(1.0, abs=0.02)
    expected = 1 + math.floor((2.0 - timing.weight_shift_s - timing.first_step_duration_s) / timing.step_duration_s + 1e-9)
    assert touchdowns["time"] == expected and touchdowns["contact"] > expected
    with pytest.raises(ConfigError, match="unknown gait_clock 'wall'"):
        EnvConfig(gait_clock="wall")


def _yawed(state: RobotState, yaw_rad: float) -> RobotState:
    turned = state.copy()
    turned.base_quat = np.array([math.cos(yaw_rad / 2), 0.0, 0.0, math.sin(yaw_rad / 2)])
    return turned


def test_the_heading_error_is_the_heading_off_the_integrated_yaw_rate_command(rng):
    """psi - (psi_0 + w_cmd t), last in the observation; beyond 0.5 rad the reference is dragged along (anti-windup)."""
    assert ObservationLayout(3, heading_error=True).size == ObservationLayout(3).size + 1
    builder = ObservationBuilder(0, heading_error=True)
    start = _yawed(random_robot_state(rng), 0.3)
    builder.reset(start)
    builder.observe(start, np.array([0.3, 0.0, 0.2]))
    later = _yawed(start, 0.3 + 0.1)
    later.time = start.time + 1.0  # the command would have turned it by 0.2 rad
    assert builder.observe(later, np.array([0.3, 0.0, 0.0]))[-1] == pytest.approx(0.1 - 0.2)
    much_later = _yawed(start, 0.3 + 0.1 + 1.0)  # turned 1 rad more while commanded straight
    much_later.time = later.time + 1.0
    assert builder.observe(much_later, np.zeros(3))[-1] == pytest.approx(0.5)
    assert builder.observe(_yawed(much_later, 0.3 + 0.1 + 0.5), np.zeros(3))[-1] == pytest.approx(0.0, abs=1e-9)
    with pytest.raises(ConfigError, match="needs observe_heading_error"):
        EnvConfig(expert_heading_correction_per_step_rad=0.1)


def test_a_heading_holding_expert_steers_the_observed_heading_error_to_zero():
    """Both setpoints (the expert's and the observation's) moved 0.3 rad to the left of a robot walking straight: the
    holding expert turns onto the new heading within 2 s and the observed error goes to zero with it; the
    rate-only expert ignores it."""
    final_error_rad = {}
    for correction in (0.0, 0.1):
        config = EnvConfig(terrains=("flat",), pushes=PushSampling(probability=0.0),
                           commands=CommandSampling(vx_mps=(0.4, 0.4), vy_mps=(0.0, 0.0), yaw_rate_radps=(0.0, 0.0),
                                                    standing_probability=0.0),
                           observe_heading_error=True, expert_heading_correction_per_step_rad=correction)
        env = WalkEnv(config)
        env.reset(0)
        for tick in range(800):  # 4 s
            if tick == 200:
                heading = yaw_of_quaternion(env.state.base_quat) + 0.3
                for setpoint in (env.builder.heading_setpoint, env.expert.controller.heading_setpoint):
                    setpoint.reset(heading, env.state.time)
            assert not env.step(env.label()[0]).terminated
        final_error_rad[correction] = env.observation[-1]
    assert abs(final_error_rad[0.1]) < 0.05 and final_error_rad[0.0] == pytest.approx(-0.3, abs=0.05)
