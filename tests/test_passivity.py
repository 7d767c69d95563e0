"""The passivity QP: its matrices against pinocchio's inverse dynamics, and its solutions (KKT, cones, limits)."""

import numpy as np
import pinocchio as pin
import pytest

from mbc.passivity import A_SLICE, NV, PassivityQp, corner_wrench_map, num_inequalities, num_variables, sole_corners
from mbc.pin_robot import PinRobot
from mbc.sim import DigitSim
from robots.digit import constants as digit


@pytest.fixture(scope="module")
def standing():
    robot = PinRobot()
    robot.update(DigitSim().reset())
    return robot


@pytest.fixture
def moving(rng):
    """A robot in a random configuration with a random velocity (the QP reads (q, v) only)."""
    robot = PinRobot()
    state = DigitSim().reset()
    state.q = state.q + rng.uniform(-0.3, 0.3, digit.NUM_JOINTS)
    state.qd, state.base_linvel, state.base_angvel = rng.normal(size=12), rng.normal(size=3), rng.normal(size=3)
    robot.update(state)
    return robot


@pytest.mark.parametrize("contact", [(True, True), (True, False), (False, True)])
def test_problem_shapes_and_cost(standing, contact):
    qp = PassivityQp()
    problem, sliding = qp.build(standing, np.array(contact), standing.q[7:], np.zeros(12), np.zeros(12))
    feet = sum(contact)
    n = num_variables(feet)
    assert problem.H.shape == (n, n) and problem.A.shape == (6, n) and problem.C.shape == (num_inequalities(feet), n)
    assert n == NV + 12 * feet  # no torque variables, no forces on a swinging foot
    np.testing.assert_allclose(problem.H, problem.H.T, rtol=1e-12, atol=1e-9)
    assert np.linalg.eigvalsh(problem.H).min() > 0  # strictly convex
    np.testing.assert_allclose(sliding, 0.0, atol=1e-12)  # at rest on target


def _corner_wrenches(robot: PinRobot, feet: tuple[int, ...], forces: np.ndarray) -> list[pin.Force]:
    """Corner forces (sole-frame components) as pinocchio external forces on the ankle joints, joint frames."""
    model, data = robot.model, robot.data
    fext = [pin.Force.Zero() for _ in range(model.njoints)]
    for side, foot_forces in zip(feet, forces.reshape(len(feet), 4, 3)):
        frame = model.frames[robot.sole_ids[side]]
        joint, sole = data.oMi[frame.parentJoint], data.oMf[robot.sole_ids[side]]
        for corner, force_sole in zip(sole_corners(), foot_forces):
            point, force = sole.act(corner), sole.rotation @ force_sole
            moment = np.cross(point - joint.translation, force)
            fext[frame.parentJoint] += pin.Force(joint.rotation.T @ force, joint.rotation.T @ moment)
    return fext


@pytest.mark.parametrize("contact", [(True, True), (True, False), (False, True)])
def test_dynamics_rows_match_inverse_dynamics_with_contact_forces(moving, rng, contact):
    """For any (a, f): A x - b = base rows and T x + t0 = joint rows of RNEA(q, v, a) with f as external forces."""
    qp = PassivityQp()
    problem, _ = qp.build(moving, np.array(contact), moving.q[7:], np.zeros(12), np.zeros(12))
    x = rng.normal(size=problem.H.shape[0]) * np.r_[np.ones(NV), 100 * np.ones(problem.H.shape[0] - NV)]
    fext = _corner_wrenches(moving, problem.feet, x[NV:])
    inverse_dynamics = pin.rnea(moving.model, moving.data, moving.q, moving.v, x[A_SLICE], fext)
    np.testing.assert_allclose(problem.A @ x - problem.b, inverse_dynamics[:6], atol=1e-8)
    np.testing.assert_allclose(problem.torque_map @ x + problem.torque_offset, inverse_dynamics[6:], atol=1e-8)


def test_corner_wrench_map_is_force_and_moment_about_the_sole(rng):
    levers, forces = rng.normal(size=(4, 3)), rng.normal(size=(4, 3))
    wrench = corner_wrench_map(levers) @ forces.ravel()
    np.testing.assert_allclose(wrench[:3], forces.sum(axis=0), atol=1e-12)
    np.testing.assert_allclose(wrench[3:], np.cross(levers, forces).sum(axis=0), atol=1e-12)


def test_standing_solution_supports_the_weight_and_satisfies_kkt(standing):
    qp = PassivityQp()
    problem, sliding = qp.build(standing, np.array([True, True]), standing.q[7:], np.zeros(12), np.zeros(12))
    result = qp.solve(standing, problem, sliding)
    assert result.solved and problem.residual(result.decision) < 1e-3
    solver = qp._solvers[2]
    y, z = solver.results.y, solver.results.z
    stationarity = problem.H @ solver.results.x + problem.g + problem.A.T @ y + problem.C.T @ z
    assert np.abs(stationarity).max() < 1e-3
    assert result.forces[:, 2].sum() == pytest.approx(digit.TOTAL_MASS_KG * 9.81, rel=0.02)
    assert np.abs(result.acceleration).max() < 0.5


def test_swing_foot_carries_no_force_and_cones_and_limits_hold(standing):
    qp = PassivityQp()
    problem, sliding = qp.build(standing, np.array([True, False]), standing.q[7:] + 0.05, np.zeros(12), np.zeros(12))
    result = qp.solve(standing, problem, sliding)
    assert result.solved and problem.residual(result.decision) < 1e-3
    np.testing.assert_array_equal(result.forces[4:], 0.0)  # right-foot corners: not variables
    left = result.forces[:4]
    mu = qp.config.friction
    assert np.all(left[:, 2] >= -1e-3)
    assert np.all(np.abs(left[:, :2]) <= mu * left[:, 2:3] + 1e-3)
    assert np.all(np.abs(result.tau_qp) <= digit.TORQUE_LIMIT_NM + 1e-3)
    assert np.all(np.abs(result.tau) <= digit.TORQUE_LIMIT_NM + 1e-9)


def test_no_foot_in_contact_is_an_error(standing):
    with pytest.raises(ValueError, match="at least one foot"):
        PassivityQp().build(standing, np.array([False, False]), standing.q[7:], np.zeros(12), np.zeros(12))


@pytest.mark.parametrize("contact", [(True, True), (True, False)])
def test_com_acceleration_of_the_solution_is_newtons_law(moving, contact):
    """The controller reads the CoM acceleration off the QP forces: m c'' = sum f + m g must hold for a(x)."""
    qp = PassivityQp()
    problem, sliding = qp.build(moving, np.array(contact), moving.q[7:], np.zeros(12), np.zeros(12))
    result = qp.solve(moving, problem, sliding)
    assert result.solved
    pin.centerOfMass(moving.model, moving.data, moving.q, moving.v, result.acceleration)
    newton = result.forces.sum(axis=0) / moving.mass + moving.model.gravity.linear
    np.testing.assert_allclose(moving.data.acom[0], newton, atol=1e-3)
    assert np.abs(result.forces).sum() > 10  # the feet do carry load


@pytest.mark.parametrize("contact", [(True, True), (False, True)])
def test_friction_rows_are_the_pyramid_of_each_corner_in_its_sole_frame(moving, rng, contact):
    qp = PassivityQp()
    problem, _ = qp.build(moving, np.array(contact), moving.q[7:], np.zeros(12), np.zeros(12))
    x = rng.normal(size=problem.H.shape[0])
    rows = problem.C[:-12] @ x
    mu = qp.config.friction
    for k in range(len(problem.feet)):
        for corner in range(4):
            fx, fy, fz = x[NV + 12 * k + 3 * corner: NV + 12 * k + 3 * corner + 3]
            expected = [fx - mu * fz, -fx - mu * fz, fy - mu * fz, -fy - mu * fz]
            np.testing.assert_allclose(rows[16 * k + 4 * corner: 16 * k + 4 * corner + 4], expected, atol=1e-12)
    assert np.all(problem.u[:-12] == 0) and np.all(problem.l[:-12] == -np.inf)


def test_result_forces_are_the_decision_rotated_into_world_axes(moving):
    qp = PassivityQp()
    problem, sliding = qp.build(moving, np.array([False, True]), moving.q[7:], np.zeros(12), np.zeros(12))
    result = qp.solve(moving, problem, sliding)
    rotation = moving.data.oMf[moving.sole_ids[1]].rotation
    np.testing.assert_allclose(result.forces[4:], result.decision[NV:].reshape(4, 3) @ rotation.T, atol=1e-12)
    np.testing.assert_array_equal(result.forces[:4], 0.0)
    assert result.vertical_force() == pytest.approx(result.forces[:, 2].sum(), abs=1e-9)


def test_a_result_is_not_changed_by_the_next_solve(standing):
    qp = PassivityQp()
    contact = np.array([True, True])
    first = qp.solve(standing, *qp.build(standing, contact, standing.q[7:], np.zeros(12), np.zeros(12)))
    decision = first.decision.copy()
    second = qp.solve(standing, *qp.build(standing, contact, standing.q[7:], np.full(12, 0.5), np.zeros(12)))
    assert np.abs(second.decision - decision).max() > 1e-3  # a different problem (a_r follows qd_des)
    np.testing.assert_array_equal(first.decision, decision)


@pytest.mark.parametrize("contact", [(True, True), (False, True)])
def test_quadratic_form_is_the_stated_cost(moving, rng, contact):
    """x'Hx/2 + g'x equals the module docstring's cost, evaluated term by term, up to a constant."""
    qp = PassivityQp()
    q_des, qd_des, qdd_des = moving.q[7:] + rng.normal(0, 0.05, 12), rng.normal(size=12), rng.normal(size=12)
    problem, _ = qp.build(moving, np.array(contact), q_des, qd_des, qdd_des)
    cfg, model, data = qp.config, moving.model, moving.data
    a_ref = qdd_des + cfg.sliding_gain * (qd_des - moving.v[6:])
    joint_weights = np.full(12, cfg.joint_weight)
    if len(problem.feet) == 1:  # the stance ankle's pitch and roll track loosely
        joint_weights[6 * problem.feet[0] + 4: 6 * problem.feet[0] + 6] *= cfg.stance_ankle_weight

    def cost(x):
        a, total = x[:NV], 0.0
        for side in problem.feet:
            frame = moving.sole_ids[side]
            foot_acceleration = (pin.getFrameJacobian(model, data, frame, pin.LOCAL) @ a
                                 + pin.getFrameClassicalAcceleration(model, data, frame, pin.LOCAL).vector
                                 + cfg.contact_damping * pin.getFrameVelocity(model, data, frame, pin.LOCAL).vector)
            total += cfg.contact_weight * foot_acceleration @ foot_acceleration
        tau = problem.torque_map @ x + problem.torque_offset
        return 0.5 * (total + joint_weights @ (a[6:] - a_ref) ** 2 + cfg.base_weight * a[:6] @ a[:6]
                      + cfg.force_weight * x[NV:] @ x[NV:] + cfg.torque_weight * tau @ tau)

    samples = [rng.normal(size=len(problem.g)) * 10 for _ in range(5)]
    offsets = [cost(x) - (0.5 * x @ problem.H @ x + problem.g @ x) for x in samples]
    np.testing.assert_allclose(offsets, offsets[0], rtol=1e-9, atol=1e-6)


def test_torque_is_the_qp_torque_minus_the_passivity_feedback(moving, rng):
    """tau = clip(tau_QP - (C s)_joints - K_D s): the Slotine-Li terms on the sliding variable s."""
    qp = PassivityQp()
    problem, sliding = qp.build(moving, np.array([True, False]), moving.q[7:] + rng.normal(0, 0.02, 12),
                                rng.normal(size=12), np.zeros(12))
    result = qp.solve(moving, problem, sliding)
    coriolis = pin.computeCoriolisMatrix(moving.model, moving.data, moving.q, moving.v)[6:, 6:]
    damping = np.tile(qp.config.damping, 2)
    expected = np.clip(result.tau_qp - coriolis @ sliding - damping * sliding, -digit.TORQUE_LIMIT_NM, digit.TORQUE_LIMIT_NM)
    np.testing.assert_allclose(result.tau, expected, atol=1e-9)
    assert np.abs(sliding).max() > 0.1  # the feedback is not trivially zero
