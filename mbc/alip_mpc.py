r"""Multi-step ALIP MPC over foot placements and step durations (casadi).

Decision variables, for N future steps and both horizontal axes a (sagittal, lateral):
u_k^a, the displacement of the contact at touchdown k (new foot minus old foot), k = 1..N, and
the durations tau_0 (time left in the current step) and tau_1..tau_N. With the closed-form flow
Phi(t) of `AlipModel`, the pre-impact states are

    s_0 = Phi(tau_0) s_now,        s_k = Phi(tau_k) (s_{k-1} - [u_k, 0]),   k = 1..N,

and the problem is

    min  sum_k |L_k - L_k^des|^2 / (m z)^2  +  w_T sum_k (tau_k - tau_k^nom)^2  +  w_u sum_k |u_k - u_k^ref|^2
    s.t. |u_k^x| <= max_step_length,  w_min <= sigma_k u_k^y <= w_max,  tau_k in [T_min, T_max],

where sigma_k = -1 when the swinging foot of step k is the right one. The step-width bounds keep
the feet apart and within reach. With timing fixed and no bound active, u_1 is exactly the
one-step-ahead law of `AlipModel.foot_placement`. The NLP is built once; each solve is warm-started
from the previous solution. With fixed timing the problem is a convex QP in the steps and an SQP
(casadi's qrqp) solves it fast; free timing (nonconvex), or an SQP failure, goes to IPOPT.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from mbc.alip import AlipModel
from mbc.errors import ConfigError
from mbc.timing import TimingConfig


@dataclass(frozen=True)
class AlipMpcConfig:
    """MPC horizon, the longest step, and weights. The step's reach and its nominal and shortest
    durations are the gait's (`StepReach`, `TimingConfig`), given to `AlipMpc` by its user."""

    horizon_steps: int = 3
    """Number of future touchdowns N."""
    max_step_duration_s: float = 0.45
    """Longest step the MPC may plan [s]."""
    min_time_left_s: float = 0.03
    """Shortest time to which the MPC may shorten the current step [s] (the swing foot must get there)."""
    timing_weight: float = 2.0
    """Weight of the duration deviations [(m/s)^2 / s^2]."""
    step_weight: float = 1e-6
    """Small weight pulling steps to a reference (regularization) [(m/s)^2 / m^2]."""

    def __post_init__(self) -> None:
        if self.horizon_steps < 1:
            raise ConfigError(f"horizon_steps must be >= 1, got {self.horizon_steps}")


@dataclass(frozen=True)
class StepReach:
    """Where a step may land: sagittal length and lateral distance between the feet [m]."""

    max_length_m: float = 0.5
    """Bound on the sagittal step |u^x| [m]."""
    min_width_m: float = 0.10
    """Smallest lateral distance between the feet at touchdown (no crossing) [m]."""
    max_width_m: float = 0.60
    """Largest lateral step [m]."""

    def __post_init__(self) -> None:
        if not (self.max_length_m > 0 and 0 < self.min_width_m < self.max_width_m):
            raise ConfigError("need max_length_m > 0 and 0 < min_width_m < max_width_m")

    def clip(self, step_x: float, step_y: float, swing_side: float) -> tuple[float, float]:
        """The step within reach: |x| <= max length; the lateral distance toward `swing_side` (+1: the swing
        foot lands to the left) within [min, max] width [m]."""
        return (min(max(step_x, -self.max_length_m), self.max_length_m),
                swing_side * min(max(swing_side * step_y, self.min_width_m), self.max_width_m))


@dataclass(frozen=True)
class MpcSolution:
    """The first step of the plan."""

    foot_from_com_m: np.ndarray
    """(2,) next foot position relative to the CoM at the planned touchdown (heading frame) [m]."""
    time_left_s: float
    """Planned time left in the current step [s]."""
    steps_m: np.ndarray
    """(N, 2) planned contact displacements u_k [m]."""
    durations_s: np.ndarray
    """(N + 1,) planned durations tau_0..tau_N [s]."""
    success: bool
    solve_time_s: float
    solver: str
    """Which solver answered: "sqp" (fast path) or "ipopt" (fallback)."""


class AlipMpc:
    """Multi-step ALIP MPC with step timing as a decision variable."""

    def __init__(self, model: AlipModel, config: AlipMpcConfig | None = None, reach: StepReach | None = None,
                 timing: TimingConfig | None = None) -> None:
        self.model = model
        self.config = config or AlipMpcConfig()
        self.reach = reach or StepReach()
        self.timing = timing or TimingConfig()
        if self.config.max_step_duration_s < self.timing.step_duration_s:
            raise ConfigError(f"max_step_duration_s ({self.config.max_step_duration_s}) is below the nominal step "
                              f"duration ({self.timing.step_duration_s})")
        self._build()
        self._warm: np.ndarray | None = None

    def reset(self) -> None:
        """Forget the warm start: the next solve starts from the reference steps and timing."""
        self._warm = None

    def _build(self) -> None:
        n = self.config.horizon_steps
        steps = ca.SX.sym("u", n, 2)
        tau = ca.SX.sym("tau", n + 1)
        # parameters: x_now (2), L_now (2), L_des (n, 2), tau_nom (n + 1), u_ref (n, 2), timing weight
        x_now, L_now = ca.SX.sym("x_now", 2), ca.SX.sym("L_now", 2)
        L_des, u_ref = ca.SX.sym("L_des", n, 2), ca.SX.sym("u_ref", n, 2)
        tau_nom, w_tau = ca.SX.sym("tau_nom", n + 1), ca.SX.sym("w_tau")
        scale = 1.0 / self.model.mz**2
        cost = w_tau * ca.sumsqr(tau - tau_nom) + self.config.step_weight * ca.sumsqr(steps - u_ref)
        for axis in range(2):
            x, L = self.model.flow(x_now[axis], L_now[axis], tau[0], ca.cosh, ca.sinh)
            for k in range(n):
                x, L = self.model.flow(x - steps[k, axis], L, tau[k + 1], ca.cosh, ca.sinh)
                cost += scale * (L - L_des[k, axis]) ** 2
        variables = ca.vertcat(ca.vec(steps), tau)
        parameters = ca.vertcat(x_now, L_now, ca.vec(L_des), tau_nom, ca.vec(u_ref), w_tau)
        problem = {"x": variables, "p": parameters, "f": cost}
        quiet = {"print_time": False, "error_on_fail": False}
        self._fast = ca.nlpsol("alip_mpc_sqp", "sqpmethod", problem, {
            **quiet, "qpsol": "qrqp", "max_iter": 10, "tol_du": 1e-9, "tol_pr": 1e-9, "print_header": False,
            "print_iteration": False, "print_status": False,
            "qpsol_options": {"print_iter": False, "print_header": False, "error_on_fail": False}})
        self._robust = ca.nlpsol("alip_mpc_ipopt", "ipopt", problem, {
            **quiet, "ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.tol": 1e-9, "ipopt.max_iter": 100})

    def solve(self, x_now, L_now, time_in_step_s: float, stance_sign: int, L_des,
              fixed_timing: bool = False) -> MpcSolution:
        """Plan from the current ALIP state (heading frame, about the stance contact).

        x_now, L_now: (2,) sagittal/lateral state; time_in_step_s: time since the current step
        began; stance_sign: +1 when the left foot is in stance (the next swing foot is the right
        one), -1 otherwise; L_des: (N, 2) desired pre-impact momenta after each touchdown;
        fixed_timing: hold all durations at their nominal values.
        """
        cfg, reach, n = self.config, self.reach, self.config.horizon_steps
        nominal, shortest = self.timing.step_duration_s, self.timing.min_step_duration_s
        x_now, L_now = np.asarray(x_now, float), np.asarray(L_now, float)
        L_des = np.broadcast_to(np.asarray(L_des, float), (n, 2))
        for name, value in (("x_now", x_now), ("L_now", L_now), ("L_des", L_des)):
            if not np.all(np.isfinite(value)):
                raise ConfigError(f"{name} must be finite, got {value}")
        if stance_sign not in (1, -1):
            raise ConfigError(f"stance_sign must be +1 (left stance) or -1 (right stance), got {stance_sign}")
        time_left = max(nominal - time_in_step_s, 0.0)
        tau_nom = np.r_[time_left, np.full(n, nominal)]
        sides = -stance_sign * (-1.0) ** np.arange(n)  # lateral direction of each step
        width = (reach.min_width_m + reach.max_width_m) / 2
        u_ref = np.c_[np.zeros(n), sides * width]
        lower_u = np.r_[np.full(n, -reach.max_length_m), np.where(sides > 0, reach.min_width_m, -reach.max_width_m)]
        upper_u = np.r_[np.full(n, reach.max_length_m), np.where(sides > 0, reach.max_width_m, -reach.min_width_m)]
        if fixed_timing:
            lower_tau = upper_tau = tau_nom
        else:
            # a step already closer to its nominal end than min_time_left is not lengthened to it
            lower_tau = np.r_[min(time_left, max(shortest - time_in_step_s, cfg.min_time_left_s)), np.full(n, shortest)]
            upper_tau = np.r_[max(cfg.max_step_duration_s - time_in_step_s, cfg.min_time_left_s),
                              np.full(n, cfg.max_step_duration_s)]
        lower, upper = np.r_[lower_u, lower_tau], np.r_[upper_u, upper_tau]
        guess = self._warm if self._warm is not None else np.r_[u_ref.T.ravel(), tau_nom]
        parameters = np.r_[x_now, L_now, L_des.T.ravel(), tau_nom, u_ref.T.ravel(), cfg.timing_weight]
        start = time.perf_counter()
        arguments = {"x0": np.clip(guess, lower, upper), "p": parameters, "lbx": lower, "ubx": upper}
        solver, success = "sqp", False
        if fixed_timing:  # a convex QP in the steps: the SQP is ~10x faster than IPOPT
            z, success = self._run(self._fast, arguments, lower, upper)
        if not success:  # free timing is nonconvex (cosh), and the active-set QP can stall
            solver = "ipopt"
            z, success = self._run(self._robust, arguments, lower, upper)
        elapsed = time.perf_counter() - start
        if success:
            self._warm = z
        else:
            z = np.clip(z if np.all(np.isfinite(z)) else arguments["x0"], lower, upper)
        steps, durations = z[: 2 * n].reshape(2, n).T, z[2 * n:]
        x_end, _ = self.model.propagate(x_now, L_now, durations[0])
        return MpcSolution(foot_from_com_m=steps[0] - x_end, time_left_s=float(durations[0]), steps_m=steps,
                           durations_s=durations, success=success, solve_time_s=elapsed, solver=solver)

    @staticmethod
    def _run(solver: ca.Function, arguments: dict, lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, bool]:
        z = np.asarray(solver(**arguments)["x"]).ravel()
        feasible = bool(np.all(np.isfinite(z)) and np.all(z >= lower - 1e-7) and np.all(z <= upper + 1e-7))
        return z, bool(solver.stats()["success"]) and feasible
