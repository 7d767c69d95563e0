"""The passivity QP: its matrices, and its solutions (KKT residuals, cones, limits)."""

import numpy as np
import pinocchio as pin
import pytest

from mbc.passivity import A_SLICE, F_SLICE, N_EQ, N_IN, N_VARS, TAU_SLICE, PassivityQp, sole_corners
from mbc.pin_robot import PinRobot
from mbc.sim import DigitSim
from robots.digit import constants as c


@pytest.fixture(scope="module")
def standing():
    robot = PinRobot()
    robot.update(DigitSim().reset())
    return robot


def test_problem_shapes_and_cost(standing):
    qp = PassivityQp()
    q = standing.q[7:]
    problem, sliding = qp.build(standing, np.array([True, True]), q, np.zeros(12), np.zeros(12))
    assert problem.H.shape == (N_VARS, N_VARS) and problem.A.shape == (N_EQ, N_VARS) and problem.C.shape == (N_IN, N_VARS)
    np.testing.assert_allclose(problem.H, problem.H.T)
    assert np.linalg.eigvalsh(problem.H).min() > 0  # strictly convex
    np.testing.assert_allclose(sliding, 0.0, atol=1e-12)  # at rest on target


def test_dynamics_rows_are_the_equations_of_motion(standing, rng):
    """A x = b holds exactly for any (a, f) when tau is the inverse dynamics and f balances the base."""
    qp = PassivityQp()
    problem, _ = qp.build(standing, np.array([True, True]), standing.q[7:], np.zeros(12), np.zeros(12))
    a = rng.normal(size=18)
    f = rng.normal(size=24)
    x = np.r_[a, f, np.zeros(12)]
    residual = problem.A @ x - problem.b  # = M a + h - J^T f - S^T tau
    x[TAU_SLICE] = residual[6:]  # the joint rows are satisfied by tau = (M a + h - J^T f)_joints
    np.testing.assert_allclose((problem.A @ x - problem.b)[6:], 0.0, atol=1e-9)
    # the corner Jacobians: J^T f equals the spatial force of the corner forces on the base rows
    model, data = standing.model, standing.data
    pin.computeAllTerms(model, data, standing.q, standing.v)
    base_rows = (problem.A[:6, A_SLICE] @ a - problem.b[:6]) - (problem.A[:6] @ x - problem.b[:6])
    corners = sole_corners()
    points = [data.oMf[fid].act(corner) for fid in standing.sole_ids for corner in corners]
    wrench_world = np.zeros(6)
    for point, force in zip(points, f.reshape(8, 3)):
        wrench_world += np.r_[force, np.cross(point - standing.q[:3], force)]
    rotation = pin.Quaternion(standing.q[3:7]).toRotationMatrix()  # base frame: pinocchio's v is local
    np.testing.assert_allclose(base_rows, np.r_[rotation.T @ wrench_world[:3], rotation.T @ wrench_world[3:]], atol=1e-8)


def test_standing_solution_supports_the_weight_and_satisfies_kkt(standing):
    qp = PassivityQp()
    problem, sliding = qp.build(standing, np.array([True, True]), standing.q[7:], np.zeros(12), np.zeros(12))
    result = qp.solve(standing, problem, sliding)
    assert result.solved and result.residual < 1e-3
    y, z = qp._qp.results.y, qp._qp.results.z
    stationarity = problem.H @ qp._qp.results.x + problem.g + problem.A.T @ y + problem.C.T @ z
    assert np.abs(stationarity).max() < 1e-3
    assert result.forces[:, 2].sum() == pytest.approx(c.TOTAL_MASS_KG * 9.81, rel=0.02)
    assert np.abs(result.acceleration).max() < 0.5


def test_swing_foot_carries_no_force_and_cones_hold(standing):
    qp = PassivityQp()
    problem, sliding = qp.build(standing, np.array([True, False]), standing.q[7:] + 0.05, np.zeros(12), np.zeros(12))
    result = qp.solve(standing, problem, sliding)
    assert result.solved
    np.testing.assert_allclose(result.forces[4:], 0.0, atol=1e-3)  # right-foot corners
    left = result.forces[:4]
    mu = qp.config.friction
    assert np.all(left[:, 2] >= -1e-3)
    assert np.all(np.abs(left[:, :2]) <= mu * left[:, 2:3] + 1e-3)
    assert np.all(np.abs(result.tau) <= c.TORQUE_LIMIT_NM + 1e-9)
    x = np.r_[result.acceleration, result.forces.ravel(), result.tau_qp]
    assert np.abs(problem.A @ x - problem.b).max() < 1e-3


def test_slices_partition_the_decision_vector():
    covered = np.zeros(N_VARS, int)
    for part in (A_SLICE, F_SLICE, TAU_SLICE):
        covered[part] += 1
    assert np.all(covered == 1)
