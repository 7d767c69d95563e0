r"""Passivity-based inverse dynamics as a QP (proxsuite), with pinocchio dynamics.

Decision vector x = [a (18), f (n_c x 4 x 3)]: generalized acceleration and a force at each of the
4 sole corners of the n_c feet in contact, in that sole's frame (so the friction pyramid rows are
constant). A swinging foot has no force variables, and the joint torques are not variables either:
the actuated rows of the dynamics give them as an affine function of x,

    tau = (M a + h - sum_feet J_sole^T G f_foot)_joints = T x + t0,          (h = C v + g)

with J_sole the sole frame's LOCAL Jacobian and G (6 x 12, constant) the wrench about the sole
origin of the corner forces. The QP keeps only what the torques cannot absorb:

    (M a + h - J_c^T G f)_base = 0                           (6 rows: the unactuated floating base)
    |f_t| <= mu f_n componentwise (sole frame)               (friction pyramid; corners: CoP in the foot)
    -tau_max <= T x + t0 <= tau_max

    min  |a_j - a_r|^2 + w_c sum_stance |J_foot a + Jdot_foot v + k_c v_foot|^2
         + w_b |a_b|^2 + w_f |f|^2 + w_tau |tau|^2

This is the problem with explicit torques and zero swing forces, with those variables substituted
out: 30 variables in single support, 42 in double (54 before), which matters because proxsuite
refactorizes the KKT system whenever a matrix changes, every tick. f_n >= 0 needs no row of its
own: f_x <= mu f_n and -f_x <= mu f_n add up to it.

Every cost term but the diagonal ones is a weighted least-squares residual, so the assembly stacks
them into one matrix R x + r (the 12 torque rows, then 6 contact-acceleration rows per stance foot)
and forms H = R^T W R + H_diag, g = R^T W r + g_joints with one product each. Numpy's per-call cost,
not arithmetic, dominates at this size (and each call evicts the others' code from the instruction
cache), so the tick keeps the number of numpy calls low. One solver per contact count
is kept, each warm-started from its own last solution, without Ruiz equilibration: the problem
is in acceleration and force units already, and equilibrating it cost 40% of the solve time while
the walking solves take ~1 iteration either way.

The stance-foot condition (no acceleration, slip velocity damped) is a heavily weighted cost rather
than an equality: with hard contact rows, touchdown impacts together with the friction cone and the
torque limits can leave no feasible point, while this QP is always feasible (f = 0 and a free base
acceleration meet the dynamics).

Passivity (Slotine-Li) on the joints: with the reference velocity qd_r = qd_des + Lambda (q_des - q)
and the sliding variable s = qd - qd_r, the joints track a_r = qdd_des + Lambda (qd_des - qd), and
the torque applied is

    tau = tau_QP - (C s)_joints - K_D s,

which equals M qdd_r + C qd_r + g - K_D s when the QP tracks exactly: the tracking error then
obeys M s' + C s + K_D s = 0, passive since M' - 2C is skew-symmetric.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from mbc.errors import ConfigError
from mbc.pin_robot import PinRobot
from mbc.qp_solver_build import import_proxsuite
from robots.digit import constants as digit

proxsuite = import_proxsuite()  # the portable build unless MBC_QP_SOLVER_BUILD=simd (mbc.qp_solver_build)

NV = 6 + digit.NUM_JOINTS
NUM_CORNERS = 4
FORCES_PER_FOOT = 3 * NUM_CORNERS
PYRAMID_ROWS = 4
A_SLICE = slice(0, NV)
"""The generalized acceleration in the decision vector; the corner forces follow it."""
_SOLVED = proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED
_TORQUE_LIMITS = digit.TORQUE_LIMIT_NM.tolist()
_NEGATIVE_TORQUE_LIMIT = -digit.TORQUE_LIMIT_NM


def num_variables(feet_in_contact: int) -> int:
    return NV + FORCES_PER_FOOT * feet_in_contact


def num_inequalities(feet_in_contact: int) -> int:
    return PYRAMID_ROWS * NUM_CORNERS * feet_in_contact + digit.NUM_JOINTS


@dataclass(frozen=True)
class PassivityConfig:
    """Gains and weights of the passivity-based QP."""

    friction: float = 0.7
    """Friction coefficient assumed by the QP (below the simulated one, for margin)."""
    sliding_gain: float = 30.0
    """Lambda: slope of the sliding surface s = e' + Lambda e [1/s]."""
    damping: tuple[float, ...] = (40.0, 30.0, 40.0, 40.0, 10.0, 4.0)
    """K_D per leg joint (hip roll .. ankle roll) [N m s / rad]."""
    joint_weight: float = 1.0
    stance_ankle_weight: float = 0.01
    """Tracking weight of the stance ankle, relative to the other joints: ALIP's pivot is nearly
    passive, so the stance-ankle torque comes from keeping the foot flat (CoP in the foot)."""
    base_weight: float = 1e-3
    force_weight: float = 1e-5
    torque_weight: float = 1e-6
    contact_weight: float = 100.0
    """w_c: weight of the stance-foot acceleration cost, relative to joint tracking."""
    contact_damping: float = 20.0
    """k_c: stance-foot velocity feedback in the contact acceleration cost [1/s]."""
    eps_abs: float = 1e-4
    """Absolute accuracy of the QP solution (forces in N, torques in N m)."""
    max_iterations: int = 200
    """Cap on proxsuite's outer and inner iterations (walking solves take ~1-20)."""

    def __post_init__(self) -> None:
        if not self.friction > 0:
            raise ConfigError(f"friction must be positive, got {self.friction}")
        if len(self.damping) != len(digit.LEG_JOINTS):
            raise ConfigError(f"damping needs {len(digit.LEG_JOINTS)} values (one per leg joint), got {len(self.damping)}")


@dataclass
class QpProblem:
    """proxsuite's dense form, min x'Hx/2 + g'x, A x = b, l <= C x <= u, and the torque map."""

    H: np.ndarray
    g: np.ndarray
    A: np.ndarray
    b: np.ndarray
    C: np.ndarray
    l: np.ndarray  # noqa: E741 (proxsuite's name)
    u: np.ndarray
    feet: tuple[int, ...]
    """The feet in contact (0 left, 1 right), in the order of their force variables."""
    sole_rotations: tuple[np.ndarray, ...]
    """(3, 3) world rotation of each sole in `feet`: its corner forces are in that frame."""
    torque_map: np.ndarray
    """(12, n) T: joint torques tau = T x + t0 [N m]."""
    torque_offset: np.ndarray
    """(12,) t0 = h_joints."""

    def residual(self, x: np.ndarray) -> float:
        """Largest equality or inequality violation at x."""
        Cx = self.C @ x
        return max(float(np.max(np.abs(self.A @ x - self.b))), float(np.max(np.maximum(Cx - self.u, self.l - Cx))))

    @staticmethod
    def sole_frame_forces(x: np.ndarray) -> np.ndarray:
        """(n_c, 4, 3) the corner forces of x, per foot in `feet`, each in its sole's frame [N]."""
        return x[NV:].reshape(-1, NUM_CORNERS, 3)

    def corner_forces_world(self, x: np.ndarray) -> np.ndarray:
        """(8, 3) corner forces of x in world axes, left foot corners first; zero on a swinging foot [N]."""
        forces = np.zeros((2, NUM_CORNERS, 3))
        for side, rotation, foot in zip(self.feet, self.sole_rotations, self.sole_frame_forces(x)):
            forces[side] = foot @ rotation.T
        return forces.reshape(2 * NUM_CORNERS, 3)


@dataclass
class QpResult:
    tau: np.ndarray
    """(12,) joint torques to apply (QP torque plus the passivity terms, clipped) [N m]."""
    tau_qp: np.ndarray
    decision: np.ndarray
    """(n,) the QP's solution x (corner forces in their sole frames)."""
    solved: bool
    iterations: int
    problem: QpProblem

    @property
    def acceleration(self) -> np.ndarray:
        """(18,) generalized acceleration of the QP (pinocchio v-space)."""
        return self.decision[A_SLICE]

    @property
    def forces(self) -> np.ndarray:
        """(8, 3) corner forces, left foot corners first, world axes; zero on a foot not in contact [N]."""
        return self.problem.corner_forces_world(self.decision)

    def vertical_force(self) -> float:
        """Sum of the corner forces' world z components [N]: per foot, the sole's z row of R times
        the sum of its corner forces."""
        forces, total = self.decision[NV:].tolist(), 0.0
        for k, rotation in enumerate(self.problem.sole_rotations):
            foot = forces[FORCES_PER_FOOT * k: FORCES_PER_FOOT * (k + 1)]
            r_zx, r_zy, r_zz = rotation[2].tolist()
            total += r_zx * sum(foot[0::3]) + r_zy * sum(foot[1::3]) + r_zz * sum(foot[2::3])
        return total


def sole_corners() -> np.ndarray:
    """(4, 3) sole corners in the sole frame [m]."""
    half_x, half_y = digit.FOOT_SIZE_M[0] / 2, digit.FOOT_SIZE_M[1] / 2
    return np.array([[sx * half_x, sy * half_y, 0.0] for sx in (1, -1) for sy in (1, -1)])


def corner_wrench_map(levers: np.ndarray) -> np.ndarray:
    """(6, 12) G = [I ... I; [r_1]x ... [r_4]x]: the wrench [f; tau] about a point of forces at 4 levers.

    levers: (4, 3) the force points minus the reference point. For the sole corners in the sole
    frame G is constant, and with the sole's LOCAL Jacobian J the generalized force of the corner
    forces (sole-frame components) is J^T G f.
    """
    G = np.zeros((6, 3 * NUM_CORNERS))
    for corner, (x, y, z) in enumerate(levers):
        G[:3, 3 * corner: 3 * corner + 3] = np.eye(3)
        G[3:, 3 * corner: 3 * corner + 3] = [[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]]
    return G


@dataclass(frozen=True)
class _Template:
    """The parts of the QP that depend only on which feet are in contact."""

    H: np.ndarray
    """Base, joint-tracking and force weights on the diagonal."""
    pyramid: np.ndarray
    """The friction-pyramid rows of C (the torque rows follow, per tick)."""
    pyramid_lower: np.ndarray
    pyramid_upper: np.ndarray
    joint_gradient: np.ndarray
    """(12,) -joint weights: the gradient of the tracking cost is this times a_r."""
    wrench_map: np.ndarray
    """(6 n_c, 12 n_c) block diagonal of -G: the stacked sole Jacobians' transpose times this is the
    force columns of the dynamics, -J_c^T G."""
    residual_weights: np.ndarray
    """(12 + 6 n_c,) W: w_tau on the torque rows, w_c on the contact-acceleration rows."""


class PassivityQp:
    """Builds and solves the passivity-based inverse-dynamics QP, warm-started each tick."""

    def __init__(self, config: PassivityConfig | None = None) -> None:
        self.config = cfg = config or PassivityConfig()
        self._damping = 2 * [float(gain) for gain in cfg.damping]  # K_D, both legs
        self._templates: dict[tuple[int, ...], _Template] = {}  # per contact set, built on first use
        self.reset()

    def reset(self) -> None:
        """Forget the warm starts: the next solve of each contact count starts cold, as on a new
        controller, so that an episode's ticks do not depend on the episode before."""
        self._solvers = {n: self._new_solver(n) for n in (1, 2)}
        self._initialized = {1: False, 2: False}

    def _template(self, feet: tuple[int, ...], joints_v: slice | np.ndarray) -> _Template:
        cfg = self.config
        n = num_variables(len(feet))
        joint_weights = np.full(digit.NUM_JOINTS, cfg.joint_weight)
        if len(feet) == 1:  # the single-support pivot: a nearly passive stance ankle
            joint_weights[feet[0] * 6 + 4: feet[0] * 6 + 6] *= cfg.stance_ankle_weight
        diagonal = np.r_[np.full(NV, cfg.base_weight), np.full(n - NV, cfg.force_weight)]
        diagonal[joints_v] = joint_weights
        mu = cfg.friction
        pyramid = np.array([[1, 0, -mu], [-1, 0, -mu], [0, 1, -mu], [0, -1, -mu]])  # on (f_x, f_y, f_z); implies f_z >= 0
        corners = NUM_CORNERS * len(feet)
        rows = np.zeros((PYRAMID_ROWS * corners, n))
        rows[:, NV:] = np.kron(np.eye(corners), pyramid)
        return _Template(H=np.diag(diagonal), pyramid=rows, pyramid_lower=np.full(len(rows), -np.inf),
                         pyramid_upper=np.zeros(len(rows)), joint_gradient=-joint_weights,  # C f <= 0
                         wrench_map=np.kron(np.eye(len(feet)), -corner_wrench_map(sole_corners())),
                         residual_weights=np.r_[np.full(digit.NUM_JOINTS, cfg.torque_weight),
                                                np.full(6 * len(feet), cfg.contact_weight)])

    def _new_solver(self, feet_in_contact: int) -> proxsuite.proxqp.dense.QP:
        cfg = self.config
        qp = proxsuite.proxqp.dense.QP(num_variables(feet_in_contact), 6, num_inequalities(feet_in_contact))
        qp.settings.eps_abs = cfg.eps_abs
        qp.settings.eps_rel = 0.0
        qp.settings.max_iter = cfg.max_iterations  # a non-converged solve is a failure, not a stall
        qp.settings.max_iter_in = cfg.max_iterations
        qp.settings.verbose = False
        qp.settings.eps_primal_inf = 1e-12  # the QP is always feasible; avoid false certificates
        qp.settings.eps_dual_inf = 1e-12
        qp.settings.initial_guess = proxsuite.proxqp.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT
        return qp

    def build(self, robot: PinRobot, contact: tuple[bool, bool] | np.ndarray, q_des: np.ndarray, qd_des: np.ndarray,
              qdd_des: np.ndarray) -> tuple[QpProblem, np.ndarray]:
        """The QP for the robot's current (q, v) and the sliding variable s (12,).

        Call `robot.update(state)` first (it leaves the kinematics and the frame accelerations at
        zero generalized acceleration, which this reads); at least one foot must be in contact.
        """
        cfg = self.config
        feet = (0, 1) if contact[0] and contact[1] else (0,) if contact[0] else (1,) if contact[1] else ()
        if not feet:
            raise ValueError("the passivity QP needs at least one foot in contact")
        joints_q, joints_v = robot.joint_map.q, robot.joint_map.v
        template = self._templates.get(feet)
        if template is None:
            template = self._templates[feet] = self._template(feet, joints_v)
        model, data, q, v = robot.model, robot.data, robot.q, robot.v
        M = pin.crba(model, data, q)
        h = pin.nonLinearEffects(model, data, q, v)
        pin.computeJointJacobians(model, data)  # from the placements of robot.update
        velocity_error = v[joints_v] - qd_des
        sliding = velocity_error - cfg.sliding_gain * (q_des - q[joints_q])
        a_ref = qdd_des - cfg.sliding_gain * velocity_error

        # rows: the dynamics M a - J_c^T G f (= S^T tau - h), then J_foot a per stance foot; rhs: h, then
        # the contact drift Jdot v + k_c v_foot (sole axes: the same norm as world axes)
        rows = np.zeros((NV + 6 * len(feet), len(template.H)))
        rhs = np.empty(len(rows))
        rows[:NV, :NV] = M
        rhs[:NV] = h
        rotations = []
        for k, side in enumerate(feet):
            frame, contact_rows = robot.sole_ids[side], slice(NV + 6 * k, NV + 6 * k + 6)
            rows[contact_rows, :NV] = pin.getFrameJacobian(model, data, frame, pin.LOCAL)
            rhs[contact_rows] = (pin.getFrameClassicalAcceleration(model, data, frame, pin.LOCAL).vector
                                 + cfg.contact_damping * pin.getFrameVelocity(model, data, frame, pin.LOCAL).vector)
            rotations.append(data.oMf[frame].rotation)
        np.matmul(rows[NV:, :NV].T, template.wrench_map, out=rows[:NV, NV:])

        residual_rows = rows[6:]  # tau = T x + t0 (weight w_tau), then the contact accelerations (w_c)
        weighted = residual_rows.T * template.residual_weights
        H = weighted @ residual_rows
        H += template.H
        g = weighted @ rhs[6:]
        g[joints_v] += template.joint_gradient * a_ref
        torque_map, torque_offset = rows[joints_v], h[joints_v]  # in JOINT_NAMES order
        problem = QpProblem(
            H=H, g=g, A=rows[:6], b=-h[:6], C=np.concatenate((template.pyramid, torque_map)),
            l=np.concatenate((template.pyramid_lower, _NEGATIVE_TORQUE_LIMIT - torque_offset)),
            u=np.concatenate((template.pyramid_upper, digit.TORQUE_LIMIT_NM - torque_offset)), feet=feet,
            sole_rotations=tuple(rotations), torque_map=torque_map, torque_offset=torque_offset)
        return problem, sliding

    def solve(self, robot: PinRobot, problem: QpProblem, sliding: np.ndarray) -> QpResult:
        """Solve (warm-started) and add the passivity terms to the QP torque."""
        feet_in_contact = len(problem.feet)
        qp = self._solvers[feet_in_contact]
        if self._initialized[feet_in_contact]:
            qp.update(problem.H, problem.g, problem.A, problem.b, problem.C, problem.l, problem.u)
        else:
            qp.init(problem.H, problem.g, problem.A, problem.b, problem.C, problem.l, problem.u,
                    compute_preconditioner=False)
            self._initialized[feet_in_contact] = True
        qp.solve()
        results = qp.results
        x = results.x.copy()  # results.x is a view that the next solve overwrites
        solved = results.info.status == _SOLVED and all(map(math.isfinite, x.tolist()))
        tau_qp = problem.torque_map @ x + problem.torque_offset
        joints_v = robot.joint_map.v
        block = (joints_v, joints_v) if isinstance(joints_v, slice) else np.ix_(joints_v, joints_v)
        coriolis_feedback = pin.computeCoriolisMatrix(robot.model, robot.data, robot.q, robot.v)[block] @ sliding
        # tau = tau_QP - C s - K_D s, clipped (in scalars: cheaper than five numpy calls on 12 values)
        tau = np.array([min(max(torque - feedback - gain * s, -limit), limit) for torque, feedback, gain, s, limit
                        in zip(tau_qp.tolist(), coriolis_feedback.tolist(), self._damping, sliding.tolist(), _TORQUE_LIMITS)])
        return QpResult(tau=tau, tau_qp=tau_qp, decision=x, solved=solved, iterations=int(results.info.iter), problem=problem)
