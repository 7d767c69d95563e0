"""DigitSim: standing, pushes, terrains, randomization hooks, input validation."""

import dataclasses

import mujoco
import numpy as np
import pytest

from mbc.errors import ConfigError
from mbc.sim import DigitSim, DomainParams, SimConfig
from mbc.types import JointCommand
from robots.digit import constants as digit


def test_a_stiff_pd_stand_keeps_robot_up_for_5_s():
    # Digit's own gains (the action space's) are too soft to hold a stand without a controller's feed-forward:
    # their PD hold sags onto the ankles, as on the robot. Ten times stiffer, the simulator's PD holds it.
    sim = DigitSim("flat", seed=0, config=SimConfig(kp=10 * digit.KP, kd=10 * digit.KD))
    state = sim.reset()
    hold = JointCommand.hold(digit.Q_STAND)
    for _ in range(int(5.0 / sim.dt)):
        state = sim.step(hold)
        assert not sim.fallen
    assert state.time == pytest.approx(5.0)
    assert state.base_pos[2] > 0.95
    assert np.all(state.contact)
    # both feet carry the weight between them
    assert state.foot_force.sum() == pytest.approx(digit.TOTAL_MASS_KG * 9.81, rel=0.05)


def test_push_changes_total_momentum_by_impulse():
    sim = DigitSim("flat")
    sim.reset()
    sim.model.opt.gravity[:] = 0.0
    sim.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    force, duration = np.array([120.0, -60.0, 30.0]), 0.2

    def momentum():
        mujoco.mj_subtreeVel(sim.model, sim.data)
        return digit.TOTAL_MASS_KG * sim.data.subtree_linvel[0].copy()

    before = momentum()
    sim.push(force, duration)
    hold = JointCommand.hold(digit.Q_STAND)
    for _ in range(int(0.3 / sim.dt)):  # the push ends mid-run; momentum is then conserved
        sim.step(hold)
    np.testing.assert_allclose(momentum() - before, force * duration, rtol=1e-3, atol=1e-3)


@pytest.mark.parametrize("angle_deg", [-10.0, 5.0, 14.0])
def test_slope_measured_incline_equals_requested(angle_deg):
    sim = DigitSim("slope", angle_deg=angle_deg, run_up_m=2.0, length_m=5.0)
    sim.reset()
    xs = np.linspace(2.2, 6.8, 12)
    heights = [sim.terrain_height(x, y) for x in xs for y in (-0.5, 0.5)]
    slope = np.polyfit(np.repeat(xs, 2), heights, 1)[0]
    assert np.rad2deg(np.arctan(slope)) == pytest.approx(angle_deg, abs=1e-6)
    assert sim.terrain_height(0.0, 0.0) == pytest.approx(0.0, abs=1e-9)  # flat run-up


def test_stairs_and_uneven_heights():
    stairs = DigitSim("stairs", step_height=0.12, step_depth=0.3, num_steps=3, run_up_m=1.5)
    stairs.reset()
    assert [round(stairs.terrain_height(1.5 + 0.3 * k + 0.15, 0.0), 6) for k in range(3)] == [0.12, 0.24, 0.36]
    uneven = DigitSim("uneven", amplitude=0.03, seed=1)
    uneven.reset()
    grid = np.array([uneven.terrain_height(x, y) for x in np.linspace(1, 8, 30) for y in np.linspace(-3, 3, 15)])
    assert np.abs(grid).max() <= 0.03 + 1e-6 and np.ptp(grid) > 0.03  # uses its amplitude, stays within it
    assert uneven.terrain_height(0.0, 0.0) == pytest.approx(0.0, abs=1e-6)  # flat start
    other_seed = DigitSim("uneven", amplitude=0.03, seed=2)
    other_seed.reset()
    assert other_seed.terrain_height(3.0, 1.0) != pytest.approx(uneven.terrain_height(3.0, 1.0))


def test_course_levels_get_harder():
    sim = DigitSim("course", num_levels=3, max_slope_deg=12.0, max_amplitude=0.03, max_step_height=0.06)
    sim.reset()
    starts = sim.terrain.level_starts_m()
    xs = np.arange(0.0, starts[-1], 0.05)
    z = np.array([sim.terrain_height(x, 0.0) for x in xs])
    grade = np.abs(np.diff(z)) / 0.05
    first, last = (xs[1:] > starts[0]) & (xs[1:] < starts[1]), xs[1:] > starts[2]
    assert grade[last].max() > grade[first].max()


def test_slope_course_levels_are_where_level_starts_says_at_their_angle():
    sim = DigitSim("course", kind="slope", num_levels=4, max_slope_deg=16.0)
    sim.reset()
    starts = sim.terrain.level_starts_m()
    for level in range(1, 5):
        xs = np.arange(starts[level - 1] + 0.01, starts[level] - 0.01, 0.02)
        z = np.array([sim.terrain_height(x, 0.0) for x in xs])
        assert np.max(np.abs(np.diff(z)) / 0.02) == pytest.approx(np.tan(np.deg2rad(16.0 * level / 4)), rel=0.02)
        assert abs(z[0]) < 1e-2 and abs(z[-1]) < 1e-2  # up and down again
    with pytest.raises(ConfigError, match="kind"):
        DigitSim("course", kind="lava")


def test_standing_robot_is_not_fallen_and_lying_robot_is():
    sim = DigitSim()
    state = sim.reset()
    assert not sim.fallen
    state.base_pos[2] = 0.3
    sim.set_state(state)
    assert sim.fallen


def test_set_state_round_trip(rng):
    sim = DigitSim()
    state = sim.reset()
    state.base_linvel, state.base_angvel, state.qd = rng.normal(size=3), rng.normal(size=3), rng.normal(size=12)
    sim.set_state(state)
    again = sim.state()
    for name in ("base_pos", "base_quat", "base_linvel", "base_angvel", "q", "qd"):
        np.testing.assert_allclose(getattr(again, name), getattr(state, name), atol=1e-12)


def test_torque_is_pd_plus_feedforward_clipped():
    sim = DigitSim()
    state = sim.reset()
    q_des = state.q + 0.01
    tau_ff = np.linspace(-5, 5, 12)
    tau_ff[3] = 1e4  # far past the knee limit: clipped
    sim.data.ctrl[:] = sim._ctrl(JointCommand(q_des, np.zeros(12), tau_ff))
    mujoco.mj_forward(sim.model, sim.data)
    expected = np.clip(sim.kp * 0.01 - sim.kd * state.qd + tau_ff, -digit.TORQUE_LIMIT_NM, digit.TORQUE_LIMIT_NM)
    np.testing.assert_allclose(sim.data.actuator_force, expected, atol=1e-9)
    assert sim.data.actuator_force[3] == pytest.approx(digit.TORQUE_LIMIT_NM[3])


def test_domain_hooks_apply_and_restore():
    sim = DigitSim()
    sim.reset()
    nominal_mass = mujoco.mj_getTotalmass(sim.model)
    sim.set_domain(DomainParams(friction=0.4, mass_scale=1.1, motor_strength=0.5, delay_s=0.002))
    assert mujoco.mj_getTotalmass(sim.model) == pytest.approx(1.1 * nominal_mass)
    assert sim.model.geom_friction[sim.model.geom("left_foot_box").id, 0] == 0.4
    np.testing.assert_allclose(sim.model.actuator_biasprm[:, 1], -0.5 * sim.kp)
    sim.set_domain(DomainParams())
    assert mujoco.mj_getTotalmass(sim.model) == pytest.approx(nominal_mass)
    np.testing.assert_allclose(sim.model.actuator_biasprm[:, 1], -sim.kp)


def test_actuator_delay_holds_previous_command():
    sim = DigitSim()
    state = sim.reset()
    sim.set_domain(DomainParams(delay_s=0.003))
    kick = JointCommand(state.q, np.zeros(12), np.full(12, 3.0))
    ctrl_before = sim.data.ctrl.copy()
    sim._advance = lambda n, advance=sim._advance: (record.append((n, sim.data.ctrl.copy())), advance(n))
    record = []
    sim.step(kick)
    assert [n for n, _ in record] == [3, 2]
    np.testing.assert_allclose(record[0][1], ctrl_before)
    np.testing.assert_allclose(record[1][1], sim._ctrl(kick))


def test_bad_input_errors_name_valid_choices():
    with pytest.raises(ConfigError, match="valid terrains.*flat"):
        DigitSim("lava")
    with pytest.raises(ConfigError, match=r"amplitude must be in \[0, 0.3\] m"):
        DigitSim("uneven", amplitude=-0.01)
    with pytest.raises(ConfigError, match=r"step_height must be in \[0, 0.3\] m, got 1.0"):
        DigitSim("stairs", step_height=1.0)
    with pytest.raises(ConfigError, match="valid parameters.*angle_deg"):
        DigitSim("slope", angel_deg=5.0)
    with pytest.raises(ConfigError, match=r"shape \(12,\)"):
        JointCommand(np.zeros(11), np.zeros(12))
    with pytest.raises(ConfigError, match="finite"):
        JointCommand(np.full(12, np.nan), np.zeros(12))
    with pytest.raises(ConfigError, match="multiple"):
        SimConfig(timestep_s=0.002, control_dt_s=0.005)
    sim = DigitSim()
    with pytest.raises(ConfigError, match="JointCommand"):
        sim.step(np.zeros(12))
    with pytest.raises(ConfigError, match="push force"):
        sim.push([1.0, 2.0], 0.1)
    with pytest.raises(ConfigError, match="delay_s must be below"):
        sim.set_domain(DomainParams(delay_s=0.01))
    with pytest.raises(ConfigError, match="kp"):
        dataclasses.replace(SimConfig(), kp=-np.ones(12))


def test_com_velocity_is_the_derivative_of_the_com_and_soles_rest_on_flat_ground():
    sim = DigitSim()
    sim.reset()
    soles = np.array([sim.sole_position(0), sim.sole_position(1)])
    np.testing.assert_allclose(soles[:, 2], 0.0, atol=5e-3)  # standing on z = 0
    assert soles[0, 1] > 0 > soles[1, 1]  # left, right
    for _ in range(20):
        sim.step(JointCommand.hold(digit.Q_STAND))
    com, velocity = sim.com_state()
    sim.step(JointCommand.hold(digit.Q_STAND))
    com_next, velocity_next = sim.com_state()
    np.testing.assert_allclose((com_next - com) / sim.dt, 0.5 * (velocity + velocity_next), atol=2e-3)


def test_joint_friction_scale_applies_and_is_checked():
    sim = DigitSim()
    nominal = sim.model.dof_frictionloss.copy()
    sim.set_domain(DomainParams(joint_friction_scale=2.5))
    np.testing.assert_allclose(sim.model.dof_frictionloss, 2.5 * nominal)
    with pytest.raises(ConfigError, match="joint_friction_scale"):
        DomainParams(joint_friction_scale=-1.0)


def _stance_sole_height(terrain: str, **params) -> float:
    """The lower sole's height after 1.5 s of the MBC stepping in place (one foot is always down) [m]."""
    from mbc import AlipController
    from mbc.rollout import run_episode
    from mbc.types import Command

    sim = DigitSim(terrain, seed=0, **params)
    run_episode(sim, AlipController.for_digit(), Command(0.0), 1.5, state=sim.reset())
    return min(sim.sole_position(foot)[2] for foot in (0, 1))


def test_soft_ground_yields_a_few_centimetres_where_flat_ground_does_not():
    flat, soft = _stance_sole_height("flat"), _stance_sole_height("soft")
    assert abs(flat) < 0.005
    assert -0.08 < soft < -0.01
    assert _stance_sole_height("soft", timeconst_s=0.02) > soft  # stiffer: less sink


def test_the_board_is_a_step_up_whose_contacts_have_its_own_friction():
    sim = DigitSim("board", seed=0, friction=0.15, height_m=0.02, run_up_m=1.0, length_m=1.0)
    board = sim.model.geom("board").id
    sim.set_domain(DomainParams(friction=0.8))  # randomization scales the board's friction as the rest
    assert sim.model.geom_friction[board, 0] == pytest.approx(0.12)
    sim.set_domain(DomainParams())
    state = sim.reset()
    assert sim.terrain_height(1.5, 0.0) == pytest.approx(0.02) and sim.terrain_height(0.5, 0.0) == pytest.approx(0.0)
    state.base_pos = state.base_pos + np.array([1.5, 0.0, 0.03])  # stand on the board
    sim.set_state(state)
    hold = JointCommand.hold(digit.Q_STAND)
    for _ in range(20):
        sim.step(hold)
    on_board = [i for i in range(sim.data.ncon) if board in sim.data.contact.geom[i]]
    assert on_board and all(sim.data.contact.friction[i][0] == pytest.approx(0.15) for i in on_board)
    with pytest.raises(ConfigError, match="board friction"):
        DigitSim("board", friction=0.0)
