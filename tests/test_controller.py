"""AlipController in the loop: short walks (the long ones are in benchmarks/), robustness, contracts."""

import copy
import warnings

import numpy as np
import pytest

from mbc.controller import AlipController
from mbc.errors import ConfigError
from mbc.fuzz import random_robot_state
from mbc.rollout import Push, perturbed_stand, run_episode
from mbc.sim import DigitSim
from mbc.types import Command
from robots.digit import constants as digit


@pytest.fixture
def controller():
    """A fresh controller per test: no state carried from one test to the next."""
    return AlipController.for_digit()


def test_walks_forward_and_tracks_velocity(controller):
    episode = run_episode(DigitSim(seed=0), controller, Command(0.4, 0.0, 0.0), 4.0)
    assert not episode.fell
    summary = episode.summary(since_s=1.5)
    assert summary["mean_vx_mps"] == pytest.approx(0.4, abs=0.05)
    assert abs(summary["mean_vy_mps"]) < 0.05
    assert controller.fallback_count == 0
    assert sum(d.touchdown for d in episode.diagnostics) >= 8  # it steps, rather than leaning


def test_mpc_foot_placement_walks():
    """The MPC option (placements and step durations over a 3-step horizon) in the loop: short walk."""
    controller = AlipController.for_digit(foot_placement="mpc")
    episode = run_episode(DigitSim(seed=0), controller, Command(0.3, 0.0, 0.0), 3.0)
    assert not episode.fell and controller.fallback_count == 0
    assert episode.summary(since_s=1.5)["mean_vx_mps"] == pytest.approx(0.3, abs=0.05)
    assert sum(d.touchdown for d in episode.diagnostics) >= 6


@pytest.mark.parametrize("correction_rad", [0.1, 0.0])
def test_a_zero_yaw_rate_holds_the_heading_up_a_steep_incline(correction_rad):
    """Up 14 deg the feet slip in yaw; landing the swing foot toward the heading setpoint keeps the walker on the fall
    line, where turning each step from the stance foot (the default) drifts (15 deg in 16 s on this seed)."""
    sim = DigitSim("slope", seed=2, angle_deg=14.0, run_up_m=1.5, length_m=8.0)
    controller = AlipController.for_digit(heading_correction_per_step_rad=correction_rad)
    episode = run_episode(sim, controller, Command(0.5), 16.0, state=perturbed_stand(sim, 2))
    assert not episode.fell and episode.arrays("base_pos")[-1, 0] > 6.0  # 4.5 m up the incline
    largest_drift_deg = np.degrees(np.abs(episode.yaw()).max())
    assert (largest_drift_deg < 5.0) if correction_rad else (largest_drift_deg > 10.0)


def test_survives_a_lateral_push_mid_stance(controller):
    episode = run_episode(DigitSim(seed=1), controller, Command(0.2, 0.0, 0.0), 4.0,
                          pushes=[Push(time_s=1.6, force_n=(0.0, 100.0, 0.0), duration_s=0.2)])
    assert not episode.fell


def test_a_step_beyond_reach_is_taken_sooner():
    """A sideways shove toward the swing foot (as after a push): the one-step law's step is wider than
    the reach, so it is clipped; with step-timing adaptation the touchdown also comes sooner."""
    sim = DigitSim(seed=2)
    walker, state = AlipController.for_digit(), sim.reset()
    while not (state.time > 1.5 and state.contact.sum() == 1 and 0.2 < walker.clock.phase < 0.4):  # early in a swing
        state = sim.step(walker.act(state, Command(0.2, 0.0, 0.0)))
    swing_side = 1.0 if state.contact[1] else -1.0  # the swing foot is on the left (+1) or right
    state.base_linvel = state.base_linvel + np.array([0.0, 0.8 * swing_side, 0.0])
    outcome = {}
    for adapt in (False, True):
        controller = AlipController.for_digit(adapt_step_timing=adapt)
        controller.reset(state)
        before = controller.clock.time_to_touchdown_s
        controller.act(state, Command(0.2, 0.0, 0.0))
        d = controller.last_diagnostics
        width = abs(d.foot_target_world[1] - d.stance_sole_world[1])  # heading along +x here
        outcome[adapt] = (before, controller.clock.time_to_touchdown_s, width)
    (before, fixed_left, fixed_width), (_, adaptive_left, adaptive_width) = outcome[False], outcome[True]
    reach = AlipController.for_digit().config.max_step_width_m
    assert fixed_left == pytest.approx(before) and fixed_width == pytest.approx(reach, abs=0.01)
    assert adaptive_left < 0.9 * before and adaptive_width == pytest.approx(reach, abs=0.01)


def test_takes_over_mid_gait_from_another_run():
    sim = DigitSim(seed=2)
    episode = run_episode(sim, AlipController.for_digit(), Command(0.3, 0.0, 0.0), 1.73)
    assert not episode.fell
    state = sim.state()
    assert state.contact.sum() == 1  # single support: mid-swing
    fresh = AlipController.for_digit()
    continued = run_episode(sim, fresh, Command(0.3, 0.0, 0.0), 3.0, state=state)
    assert not continued.fell
    assert fresh.clock.stance == fresh.last_diagnostics.stance


def test_pd_output_reproduces_the_qp_torque_at_the_tick(controller):
    sim = DigitSim()
    state = sim.reset()
    controller.reset(state)
    for _ in range(30):
        action = controller.act(state, Command(0.3, 0.0, 0.0))
        tau_pd = sim.kp * (action.q_des - state.q) + sim.kd * (action.qd_des - state.qd) + action.tau_ff
        np.testing.assert_allclose(tau_pd, controller.last_diagnostics.tau, atol=1e-9)
        state = sim.step(action)


def test_torque_output_mode():
    """The QP torque goes out as feed-forward over a PD that holds the state (so the PD adds nothing)."""
    controller = AlipController.for_digit(output="torque")
    sim = DigitSim()
    state = sim.reset()
    for _ in range(20):
        action = controller.act(state, Command(0.3))
        diagnostics = controller.last_diagnostics
        assert not diagnostics.fallback and diagnostics.assumptions.qp_solved
        assert np.abs(diagnostics.tau).max() > 10.0  # it carries the robot's weight, not a zero hold
        np.testing.assert_allclose(action.tau_ff, diagnostics.tau)
        np.testing.assert_allclose(action.q_des, state.q)
        np.testing.assert_allclose(action.qd_des, state.qd)
        state = sim.step(action)


def test_public_imports():
    import mbc

    assert mbc.AlipController is AlipController and mbc.DigitSim is DigitSim
    assert mbc.AlipModel(47.9, 0.95).omega > 0
    with pytest.raises(AttributeError):
        _ = mbc.NoSuchThing


def test_out_of_range_command_is_clipped_and_reported(controller):
    sim = DigitSim()
    state = sim.reset()
    controller.reset(state)
    controller.act(state, Command(5.0, -1.0, 0.1))
    diagnostics = controller.last_diagnostics
    assert diagnostics.command_clipped
    np.testing.assert_allclose(diagnostics.command_used, [1.0, -0.3, 0.1])
    with pytest.raises(ConfigError, match="finite"):
        Command(np.nan, 0.0, 0.0)
    with pytest.raises(ConfigError, match="unknown controller option"):
        AlipController.for_digit(step_widht_m=0.3)


def test_randomized_and_corrupted_states_never_raise(rng):
    controller = AlipController.for_digit()
    corrupted = 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for _ in range(300):
            state = random_robot_state(rng)
            if rng.random() < 0.2:
                controller.reset(state)
            implausible = not AlipController._plausible_state(state)
            before = controller.fallback_count
            action = controller.act(state, Command(*rng.uniform(-2, 2, 3)))  # a JointCommand: finite by construction
            if implausible:  # caught before any solver ran: a damped hold, counted
                assert controller.last_diagnostics.fallback and controller.fallback_count == before + 1
                assert not action.qd_des.any() and not action.tau_ff.any()
                corrupted += 1
    assert corrupted > 30


def test_implausible_states_are_recognized():
    """Each corruption of a standing state is caught by the plausibility check; the state itself passes."""
    state = DigitSim().reset()
    assert AlipController._plausible_state(state)
    corruptions = {
        "NaN joint": lambda s: s.q.__setitem__(3, np.nan), "infinite time": lambda s: setattr(s, "time", np.inf),
        "infinite velocity": lambda s: s.base_linvel.__setitem__(1, np.inf), "zero quaternion": lambda s: s.base_quat.fill(0.0),
        "base speed 25 m/s": lambda s: s.base_linvel.__setitem__(0, 25.0),
        "spin 60 rad/s": lambda s: s.base_angvel.__setitem__(2, 60.0),
        "one joint at 11x its speed limit": lambda s: s.qd.__setitem__(7, -11 * digit.SPEED_LIMIT_RADPS[7]),
    }
    for name, corrupt in corruptions.items():
        corrupted = copy.deepcopy(state)
        corrupt(corrupted)
        assert not AlipController._plausible_state(corrupted), name


def test_gait_end_momenta_are_the_alip_models():
    """The tick's step-end momentum targets, from two constants, equal AlipModel's periodic gait."""
    controller = AlipController.for_digit()
    model, T, width = controller.alip, controller.config.timing.step_duration_s, controller.config.step_width_m
    for vx, vy in ((0.0, 0.0), (0.5, -0.2), (-0.3, 0.25)):
        for sign in (1, -1):
            Lx, Ly = controller.gait_end_momenta((vx, vy, 0.0), sign)
            assert Lx == pytest.approx(model.mz * model.end_velocity_for_mean(vx, T), abs=1e-12)
            assert Ly == pytest.approx(model.lateral_end_momentum(sign, width, T, vy), abs=1e-12)
            assert Ly != pytest.approx(model.lateral_end_momentum(-sign, width, T, vy), abs=1e-3)  # the side matters


def test_a_programming_error_inside_the_tick_surfaces(controller, monkeypatch):
    """Only solver failures become fallbacks; a bug (here a TypeError in the IK call) is raised."""
    state = DigitSim().reset()
    monkeypatch.setattr(controller.ik, "solve", lambda *args: None + 1)
    with pytest.raises(TypeError):
        controller.act(state, Command(0.3))
    monkeypatch.setattr(controller.ik, "solve", lambda *args: (_ for _ in ()).throw(RuntimeError("QP failed")))
    with pytest.warns(RuntimeWarning, match="QP failed"):
        controller.act(state, Command(0.3))
    assert controller.last_diagnostics.fallback


def test_a_standing_start_shifts_weight_then_steps_without_a_lurch():
    """From a stand, the controller shifts the CoM toward the stance foot on both feet, then takes a
    short first step: the sideways speed of the first 1.5 s stays at the walking gait's own sway, and
    the first step lands beside the stance foot, not far behind and outside it."""
    sim = DigitSim()
    state = sim.reset()
    controller = AlipController.for_digit()
    controller.reset(state)
    assert controller.clock.shifting_weight
    lateral, first_step, lift_off = [], None, None
    for _ in range(600):
        action = controller.act(state, Command(0.4))
        d = controller.last_diagnostics
        if lift_off is None and not controller.clock.shifting_weight:
            lift_off = state.time
        if d.touchdown and first_step is None:
            first_step = d.stance_sole_world  # the new stance sole
        lateral.append(abs(state.base_linvel[1]))
        state = sim.step(action)
        assert not sim.fallen
    assert lift_off == pytest.approx(controller.config.timing.weight_shift_s, abs=0.006)
    start_sway, gait_sway = max(lateral[:300]), max(lateral[300:])
    assert start_sway < 1.2 * gait_sway  # was 0.63 m/s against a 0.24 m/s sway without the shift
    assert first_step[0] > -0.1 and abs(first_step[1]) < 0.15  # was (-0.24, -0.37): a catch step


def test_command_ramp_follows_a_step_at_its_rates():
    from mbc.command_ramp import CommandRamp

    ramp = CommandRamp((0.8, 0.8, 1.6))
    assert ramp((1.0, 0.0, 0.0), 0.0) == (1.0, 0.0, 0.0)  # the first command is followed at once
    followed = [ramp((-0.5, 0.2, -0.8), 0.005 * k) for k in range(1, 401)]
    steps = np.abs(np.diff(np.array([(1.0, 0.0, 0.0)] + followed), axis=0))
    assert np.all(steps <= np.array([0.004, 0.004, 0.008]) + 1e-12)
    reached = [next(k for k, f in enumerate(followed) if abs(f[axis] - target) < 1e-9) + 1
               for axis, target in enumerate((-0.5, 0.2, -0.8))]
    assert reached == [375, 50, 100]  # 1.5 m/s at 0.8 m/s^2, 0.2 m/s at 0.8, 0.8 rad/s at 1.6 rad/s^2: ticks of 5 ms
    ramp.reset()
    assert ramp((0.3, 0.0, 0.0), 2.0) == (0.3, 0.0, 0.0)


def test_command_ramp_moves_by_time_not_by_calls():
    """Called on every 4th tick only (an expert labelling a subset of states), it arrives when one called on
    every tick does: 1 m/s at 0.8 m/s^2 in 1.25 s."""
    from mbc.command_ramp import CommandRamp

    every_tick, every_fourth = CommandRamp((0.8, 0.8, 1.6)), CommandRamp((0.8, 0.8, 1.6))
    every_tick((0.0, 0.0, 0.0), 0.0), every_fourth((0.0, 0.0, 0.0), 0.0)
    for k in range(1, 301):
        dense = every_tick((1.0, 0.0, 0.0), 0.005 * k)
        if k % 4 == 0:
            sparse = every_fourth((1.0, 0.0, 0.0), 0.005 * k)
            assert sparse == pytest.approx(dense)
    assert dense[0] == pytest.approx(1.0) and every_tick.followed == (1.0, 0.0, 0.0)


def test_expert_labelling_every_fourth_state_ramps_like_one_labelling_all():
    """The expert (controller.follow on unlabelled ticks, act on labelled ones) follows a step in the command
    at the same pace whichever states it labels."""
    sim = DigitSim()
    state = sim.reset()
    dense, sparse = AlipController.for_digit(), AlipController.for_digit()
    dense.reset(state), sparse.reset(state)
    for k in range(200):
        command = Command(0.8 if k else 0.0)  # standing, then a step to 0.8 m/s
        action = dense.act(state, command)
        if k % 4 == 0:
            sparse.act(state, command)
        else:
            sparse.follow(state)
        state = sim.step(action)
    np.testing.assert_allclose(sparse._ramp.followed, dense._ramp.followed, atol=0.8 * 4 * 0.005 + 1e-9)
    assert dense._ramp.followed[0] == pytest.approx(0.8 * 199 * 0.005)  # mid-ramp: 0.8 m/s^2 for 0.995 s
