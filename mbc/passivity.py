r"""Passivity-based inverse dynamics as a QP (proxsuite), with pinocchio dynamics.

Decision vector x = [a (18), f (8 x 3), tau (12)]: generalized acceleration, a force at each of
the 4 sole corners of both feet (world axes), joint torques. With the measured (q, v):

    M a + h = S^T tau + sum_i J_i^T f_i                    (floating-base dynamics, h = C v + g)
    |f_t| <= mu f_n componentwise, f_n >= 0 (sole frame)     (friction pyramid; corners: CoP in the foot)
    f = 0 on a swinging foot;   |tau| <= tau_max

    min  |a_j - a_r|^2 + w_c sum_stance |J_foot a + Jdot_foot v + k_c v_foot|^2
         + w_b |a_b|^2 + w_f |f|^2 + w_tau |tau|^2

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

from dataclasses import dataclass

import numpy as np
import pinocchio as pin
import proxsuite

from mbc.errors import ConfigError
from mbc.pin_robot import PinRobot
from robots.digit import constants as c

NV = 6 + c.NUM_JOINTS
NUM_CORNERS = 4
NF = 2 * NUM_CORNERS * 3
N_VARS = NV + NF + c.NUM_JOINTS
N_EQ = NV
N_IN = 2 * NUM_CORNERS * 5 + c.NUM_JOINTS
A_SLICE, F_SLICE, TAU_SLICE = slice(0, NV), slice(NV, NV + NF), slice(NV + NF, N_VARS)


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
    """Cap on proxsuite's outer and inner iterations (walking solves take ~5-50)."""

    def __post_init__(self) -> None:
        if not self.friction > 0:
            raise ConfigError(f"friction must be positive, got {self.friction}")
        if len(self.damping) != len(c.LEG_JOINTS):
            raise ConfigError(f"damping needs {len(c.LEG_JOINTS)} values (one per leg joint), got {len(self.damping)}")


@dataclass
class QpProblem:
    """proxsuite's dense form: min x'Hx/2 + g'x, A x = b, l <= C x <= u."""

    H: np.ndarray
    g: np.ndarray
    A: np.ndarray
    b: np.ndarray
    C: np.ndarray
    l: np.ndarray  # noqa: E741 (proxsuite's name)
    u: np.ndarray


@dataclass(frozen=True)
class QpResult:
    tau: np.ndarray
    """(12,) joint torques to apply (QP torque plus the passivity terms, clipped) [N m]."""
    tau_qp: np.ndarray
    acceleration: np.ndarray
    """(18,) generalized acceleration of the QP (pinocchio v-space)."""
    forces: np.ndarray
    """(8, 3) corner forces, left foot corners first, world axes [N]."""
    solved: bool
    iterations: int
    residual: float
    """Largest equality/inequality violation of the returned solution."""


def sole_corners() -> np.ndarray:
    """(4, 3) sole corners in the sole frame [m]."""
    half_x, half_y = c.FOOT_SIZE_M[0] / 2, c.FOOT_SIZE_M[1] / 2
    return np.array([[sx * half_x, sy * half_y, 0.0] for sx in (1, -1) for sy in (1, -1)])


def _skew(r: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


class PassivityQp:
    """Builds and solves the passivity-based inverse-dynamics QP, warm-started each tick."""

    def __init__(self, config: PassivityConfig | None = None) -> None:
        self.config = cfg = config or PassivityConfig()
        self._corners = sole_corners()
        self._damping = np.tile(np.asarray(cfg.damping, dtype=float), 2)
        self._qp = proxsuite.proxqp.dense.QP(N_VARS, N_EQ, N_IN)
        self._qp.settings.eps_abs = cfg.eps_abs
        self._qp.settings.eps_rel = 0.0
        self._qp.settings.max_iter = cfg.max_iterations  # a non-converged solve is a failure, not a stall
        self._qp.settings.max_iter_in = cfg.max_iterations
        self._qp.settings.verbose = False
        self._qp.settings.eps_primal_inf = 1e-12  # the QP is always feasible; avoid false certificates
        self._qp.settings.eps_dual_inf = 1e-12
        self._initialized = False

    def build(self, robot: PinRobot, contact: np.ndarray, q_des: np.ndarray, qd_des: np.ndarray,
              qdd_des: np.ndarray) -> tuple[QpProblem, np.ndarray]:
        """The QP for the robot's current (q, v) (call `robot.update` first) and the sliding variable s (12,)."""
        cfg = self.config
        model, data = robot.model, robot.data
        q, v = robot.q, robot.v
        joints_q, joints_v = robot.joint_map.q, robot.joint_map.v
        pin.computeAllTerms(model, data, q, v)
        M, h = data.M, data.nle
        pin.forwardKinematics(model, data, q, v, np.zeros(model.nv))
        sliding = v[joints_v] - qd_des - cfg.sliding_gain * (q_des - q[joints_q])
        a_ref = qdd_des + cfg.sliding_gain * (qd_des - v[joints_v])

        H = np.zeros((N_VARS, N_VARS))
        g = np.zeros(N_VARS)
        base = np.arange(6)
        H[base, base] = cfg.base_weight
        weights = np.full(c.NUM_JOINTS, cfg.joint_weight)
        for side in range(2):
            if contact[side] and not contact[1 - side]:
                weights[side * 6 + 4: side * 6 + 6] *= cfg.stance_ankle_weight
        diagonal = np.arange(model.nv)[joints_v]
        H[diagonal, diagonal] = weights
        g[joints_v] = -weights * a_ref
        H[F_SLICE, F_SLICE] = cfg.force_weight * np.eye(NF)
        H[TAU_SLICE, TAU_SLICE] = cfg.torque_weight * np.eye(c.NUM_JOINTS)

        A = np.zeros((N_EQ, N_VARS))
        b = np.zeros(N_EQ)
        A[:NV, A_SLICE] = M
        A[joints_v, TAU_SLICE] = -np.eye(c.NUM_JOINTS)
        b[:NV] = -h

        C = np.zeros((N_IN, N_VARS))
        lower = np.full(N_IN, -np.inf)
        upper = np.zeros(N_IN)
        mu = cfg.friction
        pyramid = np.array([[1, 0, -mu], [-1, 0, -mu], [0, 1, -mu], [0, -1, -mu], [0, 0, -1.0]])
        for side in range(2):
            frame = robot.sole_ids[side]
            jacobian = pin.getFrameJacobian(model, data, frame, pin.LOCAL_WORLD_ALIGNED)
            rotation = data.oMf[frame].rotation
            for k, corner in enumerate(self._corners):
                column = NV + 3 * (NUM_CORNERS * side + k)
                lever = rotation @ corner
                corner_jacobian = jacobian[:3] - _skew(lever) @ jacobian[3:]
                A[:NV, column:column + 3] = -corner_jacobian.T
                row = 5 * (NUM_CORNERS * side + k)
                C[row:row + 5, column:column + 3] = pyramid @ rotation.T  # sole-frame components
                if not contact[side]:
                    lower[row + 4] = 0.0  # -f_n in [0, 0]: no force on a swinging foot
            if contact[side]:
                drift = pin.getFrameClassicalAcceleration(model, data, frame, pin.LOCAL_WORLD_ALIGNED).vector
                velocity = pin.getFrameVelocity(model, data, frame, pin.LOCAL_WORLD_ALIGNED).vector
                H[A_SLICE, A_SLICE] += cfg.contact_weight * jacobian.T @ jacobian
                g[A_SLICE] += cfg.contact_weight * jacobian.T @ (drift + cfg.contact_damping * velocity)
        torque_rows = slice(2 * NUM_CORNERS * 5, N_IN)
        C[torque_rows, TAU_SLICE] = np.eye(c.NUM_JOINTS)
        lower[torque_rows], upper[torque_rows] = -c.TORQUE_LIMIT_NM, c.TORQUE_LIMIT_NM
        return QpProblem(H, g, A, b, C, lower, upper), sliding

    def solve(self, robot: PinRobot, problem: QpProblem, sliding: np.ndarray) -> QpResult:
        """Solve (warm-started) and add the passivity terms to the QP torque."""
        qp = self._qp
        if not self._initialized:
            qp.settings.initial_guess = proxsuite.proxqp.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT
            qp.init(problem.H, problem.g, problem.A, problem.b, problem.C, problem.l, problem.u)
            self._initialized = True
        else:
            qp.update(H=problem.H, g=problem.g, A=problem.A, b=problem.b, C=problem.C, l=problem.l, u=problem.u)
        qp.solve()
        x = qp.results.x
        solved = qp.results.info.status == proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED and bool(np.isfinite(x).all())
        residual = max(float(np.max(np.abs(problem.A @ x - problem.b))),
                       float(np.max(np.maximum(problem.C @ x - problem.u, problem.l - problem.C @ x))))
        tau_qp = x[TAU_SLICE].copy()
        joints_v = robot.joint_map.v
        coriolis = pin.computeCoriolisMatrix(robot.model, robot.data, robot.q, robot.v)
        tau = tau_qp - coriolis[joints_v, joints_v] @ sliding - self._damping * sliding
        tau = np.clip(tau, -c.TORQUE_LIMIT_NM, c.TORQUE_LIMIT_NM)
        return QpResult(tau=tau, tau_qp=tau_qp, acceleration=x[A_SLICE].copy(), forces=x[F_SLICE].reshape(8, 3).copy(),
                        solved=solved, iterations=int(qp.results.info.iter), residual=residual)
