"""The closed-chain Digit: its model against the facts and the open chain, the maps between them, the
static torque map against MuJoCo's constraint Jacobian, and what stands and walks on it."""

import dataclasses

import mujoco
import numpy as np
import pytest

from mbc import AlipController
from mbc.errors import ConfigError
from mbc.passivity import PassivityConfig
from mbc.rollout import run_episode
from mbc.sim import DigitSim
from mbc.sim.closed_chain_maps import ClosedChainLegs, OpenChainLegs, stand_qpos
from mbc.sim.closed_chain_model import closed_chain_mjspec
from mbc.sim.closed_chain_sim import ClosedChainDigitSim
from mbc.types import Command, JointCommand, RobotState
from robots.digit import closed_chain_constants as cc
from robots.digit import constants as digit


@pytest.fixture(scope="module")
def sim():
    return DigitSim(robot="digit_closed_chain")


def test_model_carries_every_body_of_the_facts_with_the_open_chains_mass():
    model = closed_chain_mjspec().compile()
    assert mujoco.mj_getTotalmass(model) == pytest.approx(47.925414, abs=1e-6)
    assert mujoco.mj_getTotalmass(model) == pytest.approx(digit.TOTAL_MASS_KG, abs=1e-4)
    assert (model.nu, model.neq, model.nv) == (12, 6, 6 + 2 * 20)  # 20 leg dofs: 11 hinges, 3 balls
    rod_lengths = sorted({round(float(np.linalg.norm(model.eq_data[i, 3:6])), 4) for i in range(model.neq)})
    assert rod_lengths == [0.2881, 0.3401, 0.5012]  # toe B, toe A, achilles (facts 2.3)
    assert model.opt.timestep == cc.TIMESTEP_S


def test_selected_by_name_and_unknown_names_refused(sim):
    assert isinstance(sim, ClosedChainDigitSim) and isinstance(sim, DigitSim)
    assert type(DigitSim()) is DigitSim
    with pytest.raises(ConfigError, match="unknown robot 'cassie'; valid: \\['digit', 'digit_closed_chain'\\]"):
        DigitSim(robot="cassie")
    with pytest.raises(ConfigError, match="gains"):  # one source of gains: the action space's (robots.digit.constants)
        DigitSim(robot="digit_closed_chain", gains="facts")


def test_loops_close_at_the_stand(sim):
    legs = ClosedChainLegs()
    legs.set(stand_qpos(legs))  # Digit's reset_qpos hinge angles
    for side in range(2):
        assert np.abs(legs.loop_residual(side)[0]).max() < 1e-4
    state = sim.reset()  # the open chain's stand, as MuJoCo's constraint rows see it
    rows = sim.data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY
    assert rows.sum() == 18 and np.abs(sim.data.efc_pos[rows]).max() < 1e-4
    np.testing.assert_allclose(state.q, digit.Q_STAND, atol=1e-6)
    assert state.base_pos[2] == pytest.approx(digit.PELVIS_HEIGHT_STAND_M + 0.002)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_state_and_command_maps_round_trip(sim, seed):
    """open-chain joints -> command map (loop IK) -> closed chain -> state map (foot-pose IK) -> the same joints."""
    rng = np.random.default_rng(seed)
    sim.reset()
    leg_low, leg_high = np.array([-0.15, -0.15, -0.4, -0.5, -0.3, -0.2]), np.array([0.15, 0.15, 0.4, 0.2, 0.3, 0.2])
    q = rng.uniform(np.tile(leg_low, 2), np.tile(leg_high, 2))
    qd = rng.normal(0.0, 0.5, 12)
    state = RobotState(time=0.0, base_pos=np.array([0, 0, 1.5]), base_quat=np.array([1.0, 0, 0, 0]),
                       base_linvel=np.zeros(3), base_angvel=np.zeros(3), q=q, qd=qd, contact=np.zeros(2, bool))
    sim.set_state(state)
    rows = sim.data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY
    assert np.abs(sim.data.efc_pos[rows]).max() < 1e-6
    measured = sim.state()
    np.testing.assert_allclose(measured.q, q, atol=1e-7)
    np.testing.assert_allclose(measured.qd, qd, atol=1e-6)


def test_static_torque_map_balances_a_foot_wrench_through_mujocos_constraints():
    """tau_motor = M^T tau_open is right iff motor torques and the foot wrench W with J_open^T W = -tau_open
    are balanced by forces of MuJoCo's constraints (connects and welded springs) on every leg dof."""
    spec = closed_chain_mjspec(springs=False)
    model = spec.compile()
    data = mujoco.MjData(model)
    legs, open_legs = ClosedChainLegs(model), OpenChainLegs()
    rng = np.random.default_rng(0)
    qpos = stand_qpos(legs)
    for _ in range(4):
        q_open = rng.uniform(-0.25, 0.25, 12)
        qpos = legs.solve(qpos, legs.loop_dofs, open_legs.foot_poses(q_open), strict=True)
        data.qpos[:] = qpos
        mujoco.mj_forward(model, data)  # MuJoCo's constraint Jacobian at this configuration
        equality = data.efc_J.reshape(data.nefc, model.nv)[data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY]
        legs.set(qpos)
        open_legs.foot_poses(q_open)
        for side in range(2):
            open_jacobian = open_legs.jacobian(side)
            tau_open = rng.normal(0.0, 20.0, 6)
            wrench = -np.linalg.solve(open_jacobian.T, tau_open)
            dofs = legs.leg_dofs[side]
            for tau_motor, balanced in ((legs.motor_jacobian(side, open_jacobian).T @ tau_open, True),
                                        (tau_open, False)):  # the identity map: hips only roughly right
                applied = np.zeros(model.nv)
                applied[legs.leg_motor_dofs[side]] = tau_motor
                applied += legs.foot_jacobian(side).T @ wrench
                constraint_force = np.linalg.lstsq(equality[:, dofs].T, -applied[dofs], rcond=None)[0]
                imbalance = applied[dofs] + equality[:, dofs].T @ constraint_force
                if balanced:
                    assert np.abs(imbalance).max() < 1e-6 * np.abs(tau_open).max()
                else:
                    assert np.abs(imbalance).max() > 0.05 * np.abs(tau_open).max()


def test_motor_delay_line_applies_each_torque_six_physics_steps_late():
    sim = DigitSim(robot="digit_closed_chain")
    sim.reset()
    applied, computed = [], []
    original = sim._motor_torque
    sim._motor_torque = lambda: computed.append(original()) or computed[-1]
    advance = sim._advance
    sim._advance = lambda n: (applied.append(sim.data.ctrl.copy()), advance(n))
    for _ in range(20):  # 0.1 s: the feet land and load the legs
        sim.step(JointCommand.hold(digit.Q_STAND))
    np.testing.assert_allclose(applied[:cc.TORQUE_DELAY_STEPS], 0.0)
    np.testing.assert_allclose(applied[cc.TORQUE_DELAY_STEPS:], computed[:-cc.TORQUE_DELAY_STEPS])
    assert np.abs(computed).max() > 1.0  # torques, not zeros, went through it (the landing loads the legs)


def soft_feedback_mbc() -> AlipController:
    """The MBC with its QP's joint damping (Slotine-Li K_D) at a quarter of its default: about the action space's Kd."""
    qp = PassivityConfig()
    return AlipController.for_digit(qp=dataclasses.replace(qp, damping=tuple(0.25 * d for d in qp.damping)))


@pytest.mark.parametrize(("switch", "controller"), [({"springs": False}, AlipController.for_digit),
                                                    ({"delay": False}, soft_feedback_mbc)])
def test_mbc_stands_and_walks_on_the_closed_chain_with_springs_welded_or_without_delay(switch, controller):
    """The MBC stands 2 s and walks 5 s at 0.3 m/s on the closed chain with one of its two destabilizing parts
    switched off: untouched with the springs welded (motor delay on); on the springs (no delay) once its own joint
    feedback is as soft as the robot's gains. With both on it falls within a second (docs/closed_chain.md)."""
    for command, duration in ((Command(), 2.0), (Command(vx=0.3), 5.0)):
        sim = DigitSim(robot="digit_closed_chain", **switch)
        episode = run_episode(sim, controller(), command, duration)
        assert not episode.fell, f"fell at {episode.fall_time_s} s under {command}"
        assert episode.summary()["distance_m"] > (0.5 if command.vx else -1.0)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_command_map_gives_the_open_chains_pd_torque_at_the_mapped_state(sim, seed):
    """M^-T of the motor torque the closed chain applies at a tick is Kp (q_des - q) + Kd (qd_des - qd) + tau_ff at
    the state it handed out, exactly, for targets far from the state (a torque map, not a pose map)."""
    rng = np.random.default_rng(seed)
    sim.reset()
    for _ in range(int(rng.integers(5, 40))):  # a loaded, moving stand: springs deflected, legs in motion
        state = sim.step(JointCommand.hold(digit.Q_STAND + rng.uniform(-0.1, 0.1, 12)))
    command = JointCommand(q_des=state.q + rng.uniform(-0.8, 0.8, 12), qd_des=rng.normal(0.0, 2.0, 12),
                           tau_ff=rng.normal(0.0, 20.0, 12))
    sim._command_motors(command)
    motor_torque = sim._motor_torque()
    expected = sim.kp * (command.q_des - state.q) + sim.kd * (command.qd_des - state.qd) + command.tau_ff
    for side, jacobian in enumerate(sim._jacobians):
        leg = slice(6 * side, 6 * side + 6)
        np.testing.assert_allclose(np.linalg.solve(jacobian.T, motor_torque[leg]), expected[leg], rtol=1e-9, atol=1e-9)


def test_the_action_spaces_gains_are_digits_and_have_one_source(sim):
    """Every consumer reads robots.digit.constants KP, KD; the joint stiffness is at most twice roadrunner's
    sim-to-real motor gains seen through the closed chain's motor Jacobian at the stand (M^-T K_motor M^-1)."""
    from learn.action import ActionSpace
    from mbc.controller import AlipControllerConfig
    from mbc.sim import SimConfig

    for kp, kd in ((SimConfig().kp, SimConfig().kd), (AlipControllerConfig().kp, AlipControllerConfig().kd),
                   (ActionSpace().kp, ActionSpace().kd), (sim.kp, sim.kd), (DigitSim().kp, DigitSim().kd)):
        np.testing.assert_array_equal(kp, digit.KP)
        np.testing.assert_array_equal(kd, digit.KD)
    sim.reset()
    for side, jacobian in enumerate(sim._jacobians):
        inverse = np.linalg.inv(jacobian)
        roadrunner = np.diag(inverse.T @ np.diag([m.kp for m in cc.LEG_MOTORS]) @ inverse)
        assert np.all(digit.KP[6 * side:6 * side + 6] <= 2.0 * roadrunner), (digit.KP, roadrunner)
