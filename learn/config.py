"""Configuration of the walking task, the policy and DAgger: dataclasses with a docstring per field,
parsed from the command line by tyro in the examples. Variants are factory functions."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Literal

import tyro

from mbc.errors import ConfigError

GAIT_CLOCKS = ("contact", "time")
"""The observation's gait clock (`learn.observation.gait_timing`): 'contact', the MBC's (a step ends when the
swing foot touches down after phase 0.6, or at 1.4), or 'time', which ends every step at phase 1 whatever the
contacts (the periodic phase of Humanoid-Gym and of Radosavovic et al.)."""


def _require(condition: bool, message: str) -> None:
    if not condition:
        raise ConfigError(message)


def _check_range(name: str, bounds: tuple[float, float]) -> None:
    _require(len(bounds) == 2 and bounds[0] <= bounds[1], f"{name} must be (low, high) with low <= high, got {bounds}")


@dataclass(frozen=True)
class CommandSampling:
    """How an episode's velocity commands are drawn (heading frame)."""

    vx_mps: tuple[float, float] = (-0.5, 1.0)
    """Forward velocity range [m/s] (the AlipController's own range)."""
    vy_mps: tuple[float, float] = (-0.3, 0.3)
    """Lateral velocity range [m/s]."""
    yaw_rate_radps: tuple[float, float] = (-0.8, 0.8)
    """Yaw rate range [rad/s]."""
    standing_probability: float = 0.1
    """Probability that a command is zero (stand in place)."""
    lateral_probability: float = 0.6
    """Probability that a command has a lateral component (else vy = 0)."""
    yaw_probability: float = 0.6
    """Probability that a command has a yaw rate (else 0). With 0.35 and 0.35, one moving command in eight had
    both, and a 5 M-step PPF fell on 0.55 of the random-command trajectories (every one stepping sideways
    while turning), on 0.05-0.1 with either zeroed (docs/design.md, "combined commands"); 0.6 and 0.6: 36%."""
    resample_interval_s: tuple[float, float] = (2.5, 6.0)
    """A new command is drawn after a time uniform in this range [s]."""
    widened: bool = True
    """Whether the velocity curriculum widens the forward commands (scaling them as it does the task's range)."""

    def __post_init__(self) -> None:
        for name in ("vx_mps", "vy_mps", "yaw_rate_radps", "resample_interval_s"):
            _check_range(name, getattr(self, name))
        for name in ("standing_probability", "lateral_probability", "yaw_probability"):
            _require(0.0 <= getattr(self, name) <= 1.0, f"{name} must be in [0, 1], got {getattr(self, name)}")
        _require(self.resample_interval_s[0] > 0, "resample_interval_s must be positive")

    @classmethod
    def held(cls, vx_mps: float, vy_mps: float = 0.0, yaw_rate_radps: float = 0.0) -> CommandSampling:
        """One command for a whole episode, never resampled nor widened (the diagnostics' walks)."""
        return cls(vx_mps=(vx_mps, vx_mps), vy_mps=(vy_mps, vy_mps), yaw_rate_radps=(yaw_rate_radps, yaw_rate_radps),
                   standing_probability=0.0, lateral_probability=1.0, yaw_probability=1.0,
                   resample_interval_s=(1e9, 1e9), widened=False)


@dataclass(frozen=True)
class PushSampling:
    """Random pushes on the pelvis during an episode."""

    probability: float = 0.3
    """Probability that an episode segment gets one push."""
    force_n: tuple[float, float] = (40.0, 110.0)
    """Horizontal force magnitude range [N], in a uniformly random direction."""
    duration_s: float = 0.2
    """Push duration [s]."""

    def __post_init__(self) -> None:
        _require(0.0 <= self.probability <= 1.0, f"push probability must be in [0, 1], got {self.probability}")
        _check_range("force_n", self.force_n)
        _require(self.duration_s >= 0, f"push duration_s must be >= 0, got {self.duration_s}")


@dataclass(frozen=True)
class Randomization:
    """Dynamics randomized at each episode start (`mbc.sim.DomainParams`) and observation noise.
    Ranges are (low, high), uniform; the defaults are the nominal model (no randomization)."""

    friction: tuple[float, float] = (1.0, 1.0)
    """Sliding friction of feet and ground."""
    mass_scale: tuple[float, float] = (1.0, 1.0)
    """Scale of every link's mass and inertia, drawn per link."""
    motor_strength: tuple[float, float] = (1.0, 1.0)
    """Scale of each joint's torque, drawn per joint."""
    delay_s: tuple[float, float] = (0.0, 0.0)
    """Actuator delay within the control period [s]."""
    observation_noise: float = 0.0
    """Scale of uniform noise on the observation: times 0.05 rad/s (angular velocity), 0.03
    (projected gravity), 0.01 rad (joint angles), 0.5 rad/s (joint rates), 0.1 m/s (base velocity)."""

    def __post_init__(self) -> None:
        for name in ("friction", "mass_scale", "motor_strength", "delay_s"):
            _check_range(name, getattr(self, name))
        _require(self.observation_noise >= 0, "observation_noise must be >= 0")


def paper_randomization() -> Randomization:
    """Ranges like the paper's training (friction, masses, motor strength, delay, observation noise); the delay
    reaches the closed-chain Digit's 3 ms motor delay (`robots.digit.closed_chain_constants.TORQUE_DELAY_STEPS`)."""
    return Randomization(friction=(0.6, 1.2), mass_scale=(0.9, 1.1), motor_strength=(0.9, 1.1), delay_s=(0.0, 0.003),
                         observation_noise=1.0)


@dataclass(frozen=True)
class EnvConfig:
    """The Digit walking task."""

    terrains: tuple[str, ...] = ("flat", "flat", "flat", "uneven:amplitude=0.02", "slope:angle_deg=5",
                                 "slope:angle_deg=10", "slope:angle_deg=14", "slope:angle_deg=-5")
    """Terrains as 'name' or 'name:key=value,...' (see `mbc.sim.terrain`); environment i uses entry i mod len.
    The climbs reach the paper's steepest evaluated incline (14 deg), which the MBC climbs: on Digit's gains a
    policy distilled on +-5 deg only lost the 12 and 14 deg climbs its teacher makes. Descents stay at 5 deg,
    beyond which the MBC's own labels fall (8 deg: 0 of 3)."""
    episode_length_s: float = 20.0
    """Episodes end (truncated) after this much simulated time [s]."""
    tilt_limit_rad: float = 0.35
    """An episode ends (terminated) when the pelvis tilts more than this from upright (20 deg) [rad];
    the expert's labels beyond it are unusable."""
    history_length: int = 3
    """Past ticks of leg joint positions and velocities in the observation."""
    init_joint_noise_rad: float = 0.02
    """Uniform noise on the standing joint angles at reset [rad]."""
    init_velocity_noise_mps: float = 0.05
    """Uniform noise on the initial horizontal base velocity [m/s]."""
    commands: CommandSampling = field(default_factory=CommandSampling)
    pushes: PushSampling = field(default_factory=PushSampling)
    randomization: Randomization = field(default_factory=Randomization)
    purerl_rewards: bool = False
    """Add PureRL's reward terms (feet air time, second-order action smoothness) to the paper's table."""
    gait_clock: str = "contact"
    """The observation's gait clock, one of `GAIT_CLOCKS`: 'contact' (the expert's; a distilled policy's) or
    'time' (a step lasts its duration whatever the feet do: a stand misses the contact schedule all step long)."""
    observe_heading_error: bool = False
    """Add the heading error psi - psi_ref to the observation (`learn.observation`): psi_ref is the episode's first
    heading advanced by the commanded yaw rate. Without it a policy cannot tell a slow turn off its command from a
    held heading (the fine-tunings turn off the fall line up inclines: docs/design.md, "heading on inclines")."""
    expert_heading_correction_per_step_rad: float = 0.0
    """The expert's `AlipControllerConfig.heading_correction_per_step_rad` (0: the shipped teacher, rate only). A
    holding expert needs `observe_heading_error`: its student cannot imitate a correction to an error it cannot see."""
    lin_vel_tracking_sigma: float = 0.25
    """delta_xy of the linear velocity tracking reward exp(-|v - v_cmd|^2 / delta) [(m/s)^2]."""
    ang_vel_tracking_sigma: float = 0.25
    """delta_omega of the yaw rate tracking reward [(rad/s)^2]."""
    mean_vel_tracking_weight: float = 0.0
    """Weight of the gait-averaged velocity tracking term (`learn.rewards`, beyond the paper's table; 0: the paper's
    reward). It pays tracking the command on average, which the instantaneous term, under the sway, barely does."""
    mean_vel_tracking_sigma: float = 0.01
    """delta_mean of that term [(m/s)^2]: a drift of 0.05 m/s (the evaluation's tolerance) costs 22% of it."""
    mean_vel_time_constant_s: float = 0.5
    """Time constant of each of the two low-pass stages on the velocity error [s]: together they attenuate the
    lateral sway (the gait cycle's period, 0.7 s) about 20x and lag about 1 s."""

    def __post_init__(self) -> None:
        _require(len(self.terrains) > 0, "terrains must name at least one terrain")
        _require(self.episode_length_s > 0, f"episode_length_s must be positive, got {self.episode_length_s}")
        _require(0 < self.tilt_limit_rad < 1.5, f"tilt_limit_rad must be in (0, 1.5), got {self.tilt_limit_rad}")
        _require(self.history_length >= 0, f"history_length must be >= 0, got {self.history_length}")
        _require(self.gait_clock in GAIT_CLOCKS, f"unknown gait_clock {self.gait_clock!r}; choose from {GAIT_CLOCKS}")
        _require(self.expert_heading_correction_per_step_rad >= 0, "expert_heading_correction_per_step_rad must be >= 0, "
                 f"got {self.expert_heading_correction_per_step_rad}")
        _require(self.observe_heading_error or self.expert_heading_correction_per_step_rad == 0,
                 "an expert that holds its heading (expert_heading_correction_per_step_rad > 0) needs "
                 "observe_heading_error: the student must see the error the expert corrects")
        for name in ("lin_vel_tracking_sigma", "ang_vel_tracking_sigma", "mean_vel_tracking_sigma",
                     "mean_vel_time_constant_s"):
            _require(getattr(self, name) > 0, f"{name} must be positive, got {getattr(self, name)}")
        _require(self.mean_vel_tracking_weight >= 0,
                 f"mean_vel_tracking_weight must be >= 0 (0: off), got {self.mean_vel_tracking_weight}")


@dataclass(frozen=True)
class PolicyConfig:
    """Actor and critic networks."""

    actor_hidden: tuple[int, ...] = (512, 256, 64)
    """Hidden layer widths of the actor MLP (the paper's)."""
    critic_hidden: tuple[int, ...] = (512, 256, 64)
    """Hidden layer widths of the critic MLP."""
    init_log_std: float = -1.0
    """Initial log standard deviation of the Gaussian policy (in normalized action units)."""

    def __post_init__(self) -> None:
        _require(all(w > 0 for w in self.actor_hidden + self.critic_hidden), "hidden widths must be positive")


@dataclass(frozen=True)
class DaggerConfig:
    """DAgger: rollouts mixing expert and learner, every visited state labelled, supervised fitting."""

    iterations: int = 40
    """Rollout-and-fit iterations."""
    steps_per_env: int = 1200
    """Control ticks each environment runs per iteration (6 s at 200 Hz)."""
    beta_initial: float = 1.0
    """Probability that the expert's action is executed in iteration 0."""
    beta_decay: float = 0.6
    """beta of iteration k is beta_initial * beta_decay^k."""
    beta_min: float = 0.0
    """Floor of beta."""
    gradient_steps: int = 300
    """Minibatch updates after each iteration's rollout."""
    batch_size: int = 2048
    """Minibatch size [samples]."""
    learning_rate: float = 1e-3
    """Adam step size at iteration 0."""
    learning_rate_final: float = 1e-4
    """Adam step size at the last iteration (cosine decay in between)."""
    max_dataset_samples: int = 4_000_000
    """Keep at most this many of the most recent labelled samples in memory for fitting."""
    discard_before_fall_s: float = 0.25
    """Labels of the last this many seconds before a termination are not trained on (a falling robot) [s]."""

    def __post_init__(self) -> None:
        _require(self.iterations > 0 and self.steps_per_env > 0 and self.gradient_steps >= 0 and self.batch_size > 0,
                 "iterations, steps_per_env and batch_size must be positive, gradient_steps >= 0")
        _require(0.0 <= self.beta_min <= self.beta_initial <= 1.0, "need 0 <= beta_min <= beta_initial <= 1")
        _require(0.0 <= self.beta_decay <= 1.0, f"beta_decay must be in [0, 1], got {self.beta_decay}")
        _require(self.learning_rate > 0 and self.learning_rate_final > 0, "learning rates must be positive")

    def beta(self, iteration: int) -> float:
        """Probability of executing the expert's action in `iteration`."""
        return max(self.beta_initial * self.beta_decay ** iteration, self.beta_min)


@dataclass(frozen=True)
class WorkerConfig:
    """Parallel simulation."""

    workers: int = 2
    """Worker processes, or Ray actors with `backend="ray"` (0: run the environments in this process)."""
    envs_per_worker: int = 8
    """Environments per worker; the policy runs batched over them."""
    backend: Annotated[Literal["process", "ray"], tyro.conf.arg(prefix_name=False)] = "process"
    """Where the workers run: processes on this machine, or actors of a Ray cluster (`pip install -e '.[ray]'`)."""
    ray_address: Annotated[str | None, tyro.conf.arg(prefix_name=False)] = None
    """The Ray cluster to join ('auto' on one of its nodes, or 'ray://HEAD:10001'); None: a local cluster, which is
    started only where loopback is the only network interface (`learn.ray_vec_env`, docs/cluster.md)."""

    def __post_init__(self) -> None:
        _require(self.workers >= 0 and self.envs_per_worker > 0, "workers must be >= 0 (0: in this process) and "
                 f"envs_per_worker >= 1, got workers={self.workers}, envs_per_worker={self.envs_per_worker}")
        _require(self.backend in ("process", "ray"), f"backend must be 'process' or 'ray', got {self.backend!r}")
        _require(self.backend == "process" or self.workers >= 1, "the ray backend needs workers >= 1 (actors)")
        _require(self.ray_address is None or self.backend == "ray", "ray_address is for backend='ray'")

    @property
    def num_envs(self) -> int:
        return max(self.workers, 1) * self.envs_per_worker


@dataclass(frozen=True)
class DistillConfig:
    """A DAgger distillation run: where it writes, its seed, and the parts' settings."""

    run_dir: Path = Path("runs/distill")
    """Directory of the run: resolved config, TensorBoard logs, dataset shards, checkpoints."""
    seed: int = 0
    """Seed of the rollouts and of the minibatch sampling."""
    resume: bool = False
    """Continue the run in `run_dir` from its last checkpoint (same schedule, no labelled sample lost)."""
    env: EnvConfig = field(default_factory=EnvConfig)
    policy: PolicyConfig = field(default_factory=PolicyConfig)
    dagger: DaggerConfig = field(default_factory=DaggerConfig)
    workers: WorkerConfig = field(default_factory=WorkerConfig)
    device: str = "cpu"
    """Where the fit runs: 'cpu', or 'cuda' when torch sees a GPU (the rollouts stay on the CPU workers)."""
