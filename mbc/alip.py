r"""The angular-momentum linear inverted pendulum (ALIP), exact and vectorized.

Per horizontal axis, with CoM position x relative to the stance contact point, angular momentum
L about the contact point, constant CoM height z and ankle torque u:

    x' = L / (m z),        L' = m g x + u.

With omega = sqrt(g / z) the flow over t is, for constant u and x~ = x + u / (m g),

    [x~(t)]   [ cosh(wt)          sinh(wt) / (m z w) ] [x~(0)]
    [L (t)] = [ m z w sinh(wt)    cosh(wt)           ] [L (0)].

Axis convention: L is the pendulum momentum m z x' (for z' = 0). Sagittal: L = L_y about the
contact; lateral: L = -L_x (so that L = m z y'). The orbital energy
E = (L / (m z))^2 / 2 - omega^2 x^2 / 2 is conserved for u = 0.

At touchdown the contact moves by the step u_step; with z' = 0 the angular momentum about the new
contact equals that about the old one, so the step-to-step map between pre-impact states is
s+ = A(T) (s - [u_step, 0]) = A(T) s + B(T) u_step.
"""

from __future__ import annotations

import math

import numpy as np

from mbc.errors import ConfigError


def _positive(name: str, value: float) -> float:
    value = float(value)
    if not (np.isfinite(value) and value > 0):
        raise ConfigError(f"{name} must be positive and finite, got {value}")
    return value


def _finite(name: str, value) -> np.ndarray | float:
    """`value` as a float (scalars, the fast path of the control loop) or a float array, if finite."""
    if isinstance(value, float | int):
        if not math.isfinite(value):
            raise ConfigError(f"{name} must be finite, got {value}")
        return float(value)
    array = np.asarray(value, dtype=float)
    if not np.isfinite(array).all():
        raise ConfigError(f"{name} must be finite, got {value}")
    return array


def _durations(name: str, value, allow_zero: bool = False) -> np.ndarray | float:
    checked = _finite(name, value)
    smallest = checked if isinstance(checked, float) else (checked.min() if checked.size else 1.0)
    if smallest < 0 or (smallest == 0 and not allow_zero):
        raise ConfigError(f"{name} must be {'>= 0' if allow_zero else 'positive'} (a duration), got {value}")
    return checked


class AlipModel:
    """ALIP of mass `mass` [kg] at constant CoM height `com_height` [m] above the contact."""

    def __init__(self, mass: float, com_height: float, gravity: float = 9.81) -> None:
        self.mass = _positive("mass", mass)
        self.com_height = _positive("com_height", com_height)
        self.gravity = _positive("gravity", gravity)
        self.omega = float(np.sqrt(self.gravity / self.com_height))
        """Natural frequency sqrt(g / z) [1/s]."""

    def __repr__(self) -> str:
        return f"AlipModel(mass={self.mass}, com_height={self.com_height}, gravity={self.gravity})"

    @property
    def mz(self) -> float:
        return self.mass * self.com_height

    def flow(self, x, L, t, cosh=np.cosh, sinh=np.sinh):
        """The closed-form flow without ankle torque, the one place it is written:
        x(t) = cosh(wt) x + sinh(wt) L / (m z w),  L(t) = m z w sinh(wt) x + cosh(wt) L.

        No checks; `cosh`/`sinh` select the arithmetic: numpy (default, broadcasting), `math` for
        plain floats in the control tick, casadi's for symbols in the MPC."""
        wt, mzw = self.omega * t, self.mz * self.omega
        ch, sh = cosh(wt), sinh(wt)
        return ch * x + sh * L / mzw, mzw * sh * x + ch * L

    def propagate(self, x, L, t, u_ankle=0.0) -> tuple[np.ndarray, np.ndarray]:
        """State (x [m], L [kg m^2/s]) after time t [s] >= 0 under constant ankle torque [N m].

        All arguments broadcast against each other. A constant ankle torque u shifts the equilibrium
        to x = -u / (m g): the torque-free flow of x + u / (m g).
        """
        x, L, u = _finite("x", x), _finite("L", L), _finite("u_ankle", u_ankle)
        t = _durations("t", t, allow_zero=True)
        shift = u / (self.mass * self.gravity)
        x_t, L_t = self.flow(x + shift, L, t)
        return x_t - shift, L_t

    def transition_matrix(self, t: float) -> np.ndarray:
        """(2, 2) A(t) with [x, L](t) = A(t) [x, L](0) for zero ankle torque: the flow of the unit states."""
        t = float(_durations("t", t, allow_zero=True))
        return np.array(self.flow(np.eye(2)[0], np.eye(2)[1], t))

    def step_to_step(self, T: float) -> tuple[np.ndarray, np.ndarray]:
        """(A, B) of the pre-impact map s_next = A s + B u_step for a step of duration T [s].

        s = [x, L] just before touchdown (x relative to the stance contact), u_step = new contact
        minus old contact along the axis [m].
        """
        A = self.transition_matrix(T)
        return A, -A[:, 0]

    def foot_placement(self, L_end, v_des, T) -> np.ndarray:
        """Next foot position relative to the CoM at touchdown (one-step-ahead law) [m].

        Chosen so that one step of duration T later the momentum is L = m z v_des:
            p = (L_end cosh(wT) / (m z) - v_des) / (w sinh(wT)).
        """
        L_end, v_des, T = _finite("L_end", L_end), _finite("v_des", v_des), _durations("T", T)
        wt = self.omega * T
        return (L_end * np.cosh(wt) / self.mz - v_des) / (self.omega * np.sinh(wt))

    def one_step_placement(self, x: float, L: float, time_left: float, L_des: float, T: float) -> float:
        """Next contact minus the current one along one axis, by the one-step-ahead law [m].

        (x, L) now flows for `time_left` [s] to touchdown, (x_e, L_e) = A(time_left) (x, L); the foot
        then lands at x_e + `foot_placement`(L_e, L_des / (m z), T), so that the step after ends with
        momentum L_des. Plain floats and no checks: this runs every control tick.
        """
        wT, mzw = self.omega * T, self.mz * self.omega
        x_end, L_end = self.flow(x, L, time_left, math.cosh, math.sinh)
        return x_end + (L_end * math.cosh(wT) - L_des) / (mzw * math.sinh(wT))

    def time_left_for_step(self, x: float, L: float, L_des: float, T: float, step: float,
                           earliest: float, latest: float) -> float | None:
        """The latest time to touchdown in [earliest, latest] at which `one_step_placement` is `step` [s].

        With u = exp(w t) the placement is p(u) = a u + b / u - K, where
            a = (1 + coth wT) (x + L / (m z w)) / 2,  b = (1 - coth wT) (x - L / (m z w)) / 2,
            K = L_des / (m z w sinh wT),
        so p(u) = step is the quadratic a u^2 - (step + K) u + b = 0. None when no root is in range.
        The step-timing adaptation: when the placement saturates, touch down when it fits the bound.
        """
        wT, mzw = self.omega * T, self.mz * self.omega
        coth, xi, eta = 1.0 / math.tanh(wT), x + L / mzw, x - L / mzw
        a, b = 0.5 * (1.0 + coth) * xi, 0.5 * (1.0 - coth) * eta
        k = step + L_des / (mzw * math.sinh(wT))
        if abs(a) < 1e-12:
            roots = [b / k] if k else []
        else:
            discriminant = k * k - 4.0 * a * b
            if discriminant < 0:
                return None
            root = math.sqrt(discriminant)
            roots = [(k + root) / (2.0 * a), (k - root) / (2.0 * a)]
        times = [math.log(u) / self.omega for u in roots if u > 0]
        times = [t for t in times if earliest <= t <= latest]
        return max(times) if times else None

    def end_velocity_for_mean(self, v_mean, T) -> np.ndarray:
        """Velocity at the step's end of the periodic gait whose mean velocity is v_mean [m/s].

        In a periodic ALIP gait the CoM is slowest mid-step: v_end = v_mean (wT/2) / tanh(wT/2).
        Feed this to `foot_placement` to track a mean walking velocity.
        """
        half = self.omega * _durations("T", T) / 2
        return _finite("v_mean", v_mean) * half / np.tanh(half)

    def lateral_end_momentum(self, stance_sign, step_width, T, v_mean=0.0) -> np.ndarray:
        """L at the end of a stance of the periodic two-step lateral gait [kg m^2/s].

        stance_sign: +1 for left stance (the CoM passes right of the left foot, heading right),
        -1 for right stance; step_width: lateral distance between the feet [m]. The gait
        alternates +-(m z W w / 2) tanh(wT/2) on top of the mean-velocity momentum.
        """
        width, T = _finite("step_width", step_width), _durations("T", T)
        swing = 0.5 * self.mz * width * self.omega * np.tanh(self.omega * T / 2)
        return -np.asarray(stance_sign) * swing + self.mz * self.end_velocity_for_mean(v_mean, T)

    def orbital_energy(self, x, L) -> np.ndarray:
        """(L / (m z))^2 / 2 - w^2 x^2 / 2, conserved along the flow without ankle torque."""
        return 0.5 * (np.asarray(L) / self.mz) ** 2 - 0.5 * self.omega**2 * np.asarray(x) ** 2


class GaitEndMomenta:
    """Step-end momentum targets (L_x, L_y) of the periodic gait for a command: `AlipModel.end_velocity_for_mean`
    and `lateral_end_momentum`, which are linear in the command, from two constants (this runs every tick):

        L_x = m z v_end(1) vx,    L_y = m z v_end(1) vy - s L_lat,

    with s = +1 at the end of a left stance, -1 of a right one (an array for a sequence of steps) [kg m^2/s]."""

    def __init__(self, model: AlipModel, step_duration_s: float, step_width_m: float) -> None:
        self.per_velocity = model.mz * float(model.end_velocity_for_mean(1.0, step_duration_s))
        self.lateral = float(model.lateral_end_momentum(-1, step_width_m, step_duration_s))
        """m z W w / 2 tanh(w T / 2): the lateral gait's step-end momentum at zero velocity [kg m^2/s]."""

    def __call__(self, command, stance_sign):
        return self.per_velocity * command[0], self.per_velocity * command[1] - stance_sign * self.lateral
