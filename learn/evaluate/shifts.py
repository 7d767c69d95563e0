"""Domain shifts: the simulator (or the sensing) changed one way at a time, so that every protocol can
be run where no controller was tuned and no policy was trained.

Physical shifts set `mbc.sim.DomainParams` on the simulator; sensing shifts wrap the controller in
`ShiftedSensing`, which hands it a noisy or late copy of the measured state (the simulator is untouched);
robot shifts run another robot model behind the same interface (`DigitSim(robot=...)`): the closed-chain
Digit, the transfer test.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np

from mbc.errors import ConfigError
from mbc.sim import DigitSim, DomainParams
from mbc.types import Command, Controller, JointCommand, RobotState


@dataclass(frozen=True)
class SensorNoise:
    """Half-widths of uniform noise on the measured state."""

    joint_angle_rad: float = 0.0
    joint_rate_radps: float = 0.0
    base_angvel_radps: float = 0.0
    base_linvel_mps: float = 0.0


@dataclass(frozen=True)
class Shift:
    """One change from the nominal simulation; `describe` is the row of the documentation's table."""

    name: str
    describe: str
    mass_scale_range: tuple[float, float] = (1.0, 1.0)
    """Each link's mass and inertia scaled by a factor uniform in this range, drawn per link and seed."""
    com_offset_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    joint_friction_scale: float = 1.0
    motor_strength: float = 1.0
    delay_s: float = 0.0
    noise: SensorNoise = field(default_factory=SensorNoise)
    latency_ticks: int = 0
    robot: str = "digit"
    """The simulated robot (`DigitSim(robot=...)`)."""
    robot_options: tuple[tuple[str, object], ...] = ()
    """Keywords of that robot's simulator, e.g. (("springs", False),)."""

    def simulator(self, terrain: str, seed: int, **terrain_params) -> DigitSim:
        """The shifted robot's simulator on `terrain` (the physical and sensing shifts come with `apply`)."""
        return DigitSim(terrain, seed=seed, robot=self.robot, **dict(self.robot_options), **terrain_params)

    def domain(self, sim: DigitSim, seed: int) -> DomainParams:
        rng = np.random.default_rng(10_000 + seed)
        return DomainParams(mass_scale=rng.uniform(*self.mass_scale_range, sim.model.nbody),
                            com_offset_m=np.array(self.com_offset_m), joint_friction_scale=self.joint_friction_scale,
                            motor_strength=self.motor_strength, delay_s=self.delay_s)

    def apply(self, sim: DigitSim, controller: Controller, seed: int) -> Controller:
        """Set the physical shift on `sim`; return the controller, wrapped when the sensing is shifted."""
        sim.set_domain(self.domain(sim, seed))
        if self.noise != SensorNoise() or self.latency_ticks:
            return ShiftedSensing(controller, self.noise, self.latency_ticks, seed)
        return controller


SHIFTS = {shift.name: shift for shift in (
    Shift("nominal", "the simulator every controller was tuned and every policy trained in"),
    Shift("link_mass", "each link's mass and inertia x U(0.8, 1.2), drawn per link", mass_scale_range=(0.8, 1.2)),
    Shift("com_offset", "pelvis CoM 3 cm forward and 2 cm to the left of the model's", com_offset_m=(0.03, 0.02, 0.0)),
    Shift("joint_friction", "leg joints' dry friction x4 (2-4 N m)", joint_friction_scale=4.0),
    Shift("weak_motors", "every joint's torque at 85% of the command", motor_strength=0.85),
    Shift("actuator_delay", "a command takes effect 3 ms into its 5 ms control period", delay_s=0.003),
    Shift("sensor_noise", "uniform noise on the state the controller reads: joint angles +-0.02 rad, rates "
          "+-0.5 rad/s, base angular velocity +-0.1 rad/s, base velocity +-0.1 m/s",
          noise=SensorNoise(0.02, 0.5, 0.1, 0.1)),
    Shift("sensor_latency", "the controller reads the state of 2 ticks (10 ms) before", latency_ticks=2),
    Shift("closed_chain", "Digit's closed-chain legs (rods, knee and heel springs, 3 ms motor delay; "
          "`mbc.sim.closed_chain_sim`) behind the open chain's interface", robot="digit_closed_chain"),
    Shift("closed_chain_rigid", "the closed chain with its springs welded (rods and motor delay kept)",
          robot="digit_closed_chain", robot_options=(("springs", False),)),
)}


def get_shift(name: str) -> Shift:
    if name not in SHIFTS:
        raise ConfigError(f"unknown shift {name!r}; valid: {list(SHIFTS)}")
    return SHIFTS[name]


class ShiftedSensing:
    """A `Controller` that reads the measured state `latency_ticks` late and with uniform noise; its other
    attributes (gains, command limits, diagnostics) are the wrapped controller's."""

    def __init__(self, controller: Controller, noise: SensorNoise, latency_ticks: int, seed: int) -> None:
        self.controller, self.noise, self.latency_ticks = controller, noise, latency_ticks
        self.rng = np.random.default_rng(20_000 + seed)
        self._states: deque[RobotState] = deque(maxlen=latency_ticks + 1)

    def __getattr__(self, name: str):
        return getattr(self.controller, name)

    def reset(self, state: RobotState) -> None:
        self._states.clear()
        self.controller.reset(state)

    def act(self, state: RobotState, command: Command) -> JointCommand:
        self._states.append(state.copy())
        seen = self._states[0].copy()  # the oldest kept: latency_ticks old once the buffer is full
        n = self.noise
        seen.q = seen.q + self.rng.uniform(-1, 1, seen.q.shape) * n.joint_angle_rad
        seen.qd = seen.qd + self.rng.uniform(-1, 1, seen.qd.shape) * n.joint_rate_radps
        seen.base_angvel = seen.base_angvel + self.rng.uniform(-1, 1, 3) * n.base_angvel_radps
        seen.base_linvel = seen.base_linvel + self.rng.uniform(-1, 1, 3) * n.base_linvel_mps
        return self.controller.act(seen, command)
