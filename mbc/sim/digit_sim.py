"""`DigitSim`: the simulated Digit that controllers and learners drive.

One `step` advances one control period (default 5 ms = 5 physics steps of 1 ms). The joint PD
law tau = Kp (q_des - q) + Kd (qd_des - qd) + tau_ff runs inside MuJoCo at the physics rate, as
an affine actuator clipped to the torque limits (see `mbc.robot.digit_mjspec`), so the wrapper
adds one `ctrl` write and one state read per control period. The limits follow Digit's motor model
(`mbc.sim.motor`, the closed chain's too): the torque-speed line at the joint speeds of the period's
start, written into the actuators' force ranges once per control period.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import ClassVar

import mujoco
import numpy as np

from mbc.errors import ConfigError, MbcError
from mbc.robot import JointMap, as_slice, digit_mjspec
from mbc.sim.domain import DomainParams
from mbc.sim.motor import TorqueSpeedLine
from mbc.sim.terrain import TERRAIN_GROUP, TerrainConfig, add_terrain, make_terrain
from mbc.types import CONTROL_PERIOD_S, JointCommand, RobotState
from robots.digit import constants as digit

JOINT_LINE = TorqueSpeedLine(digit.TORQUE_LIMIT_NM, digit.SPEED_LIMIT_RADPS)
"""The open chain's joints' torque limits and torque-speed lines (Digit's motors through the leg)."""


@dataclass(frozen=True)
class SimConfig:
    """Simulation settings."""

    timestep_s: float = 0.001
    """Physics step [s]; the PD law runs at this rate."""
    control_dt_s: float = CONTROL_PERIOD_S
    """Control period [s]: one `step` call."""
    kp: np.ndarray = field(default_factory=lambda: digit.KP.copy())
    """(12,) joint stiffness [N m / rad]."""
    kd: np.ndarray = field(default_factory=lambda: digit.KD.copy())
    """(12,) joint damping [N m s / rad]."""
    fall_height_m: float = 0.6
    """The robot has fallen when the pelvis is less than this above the terrain below it [m]."""
    contact_threshold_n: float = 20.0
    """A foot is in contact when its normal force exceeds this [N]."""

    def __post_init__(self) -> None:
        ratio = self.control_dt_s / self.timestep_s
        if self.timestep_s <= 0 or abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            raise ConfigError(f"control_dt_s ({self.control_dt_s}) must be a positive multiple of "
                              f"timestep_s ({self.timestep_s})")
        for name in ("kp", "kd"):
            gains = np.asarray(getattr(self, name), dtype=float)
            if gains.shape != (digit.NUM_JOINTS,) or np.any(gains < 0) or not np.all(np.isfinite(gains)):
                raise ConfigError(f"{name} must be ({digit.NUM_JOINTS},) non-negative finite gains, got {gains}")

    @property
    def substeps(self) -> int:
        return int(round(self.control_dt_s / self.timestep_s))


class DigitSim:
    """Simulated Digit on a named terrain.

    >>> sim = DigitSim("slope", angle_deg=5.0, seed=0)
    >>> state = sim.reset()
    >>> state = sim.step(JointCommand.hold(state.q))

    `robot="digit_closed_chain"` gives Digit's closed-chain leg behind the same interface
    (`mbc.sim.closed_chain_sim`): a transfer simulator that nothing is tuned or trained on.
    """

    robot_name = "digit"
    """The name that selects this simulator's robot in `DigitSim(..., robot=NAME)`."""
    robots: ClassVar[dict[str, type[DigitSim]]] = {}
    """Every simulator selectable by `robot=`: each subclass registers itself by its `robot_name` (`mbc.sim`
    imports them all), so this module imports none of them."""

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        DigitSim.robots[cls.robot_name] = cls

    def __new__(cls, *args, robot: str = "digit", **kwargs):
        if cls is DigitSim and robot != cls.robot_name:
            if robot not in DigitSim.robots:
                raise ConfigError(f"unknown robot {robot!r}; valid: {sorted(DigitSim.robots)}")
            cls = DigitSim.robots[robot]
        return super().__new__(cls)

    def __init__(self, terrain: str | TerrainConfig = "flat", *, seed: int = 0, config: SimConfig | None = None,
                 viewer: bool = False, robot: str = "digit", **terrain_params) -> None:
        self.config = config or self.default_config()
        self.terrain = make_terrain(terrain, **terrain_params) if isinstance(terrain, str) else terrain
        if not isinstance(terrain, str) and terrain_params:
            raise ConfigError("pass terrain parameters either in a terrain config or as keywords, not both")
        self.rng = np.random.default_rng(seed)
        spec = self._robot_spec()
        spec.option.timestep = self.config.timestep_s
        spec.worldbody.add_light(name="sun", pos=[0, 0, 4], dir=[0, 0.3, -1])
        add_terrain(spec, self.terrain, self.rng)
        self.model: mujoco.MjModel = spec.compile()
        self.data = mujoco.MjData(self.model)
        self.dt = self.config.control_dt_s
        self._pelvis = self.model.body(digit.BASE_LINK).id
        self._touch_adr = as_slice([self.model.sensor_adr[self.model.sensor(f"{f}_touch").id] for f in digit.FOOT_LINKS])
        self._is_terrain = self.model.geom_group == TERRAIN_GROUP
        foot_geoms = [self.model.geom(f"{f}_box").id for f in digit.FOOT_LINKS]
        self._is_body_part = (~self._is_terrain) & (self.model.geom_bodyid > 0)
        self._is_body_part[foot_geoms] = False
        self._foot_geoms = foot_geoms
        self._nominal = {"body_mass": self.model.body_mass.copy(), "body_inertia": self.model.body_inertia.copy(),
                         "geom_friction": self.model.geom_friction.copy(), "body_ipos": self.model.body_ipos.copy(),
                         "dof_frictionloss": self.model.dof_frictionloss.copy()}
        self._ray_groups = np.zeros(6, np.uint8)
        self._ray_groups[TERRAIN_GROUP] = 1
        self._ray_geom = np.zeros(1, np.int32)
        self._strength = np.ones(digit.NUM_JOINTS)
        self._delay_substeps = 0
        self._push_substeps_left = 0
        self._bind_robot()
        self._set_gains(self.config.kp, self.config.kd)
        self.domain = DomainParams()
        self._viewer = self._open_viewer() if viewer else None

    @classmethod
    def default_config(cls) -> SimConfig:
        """The simulation settings this robot uses unless given others."""
        return SimConfig()

    def _robot_spec(self) -> mujoco.MjSpec:
        """The robot's MuJoCo spec (before the terrain is added)."""
        return digit_mjspec()

    def _bind_robot(self) -> None:
        """Locate the robot's joints in the compiled model."""
        self.joint_map = JointMap.for_mujoco(self.model)
        self._forcerange = self.model.actuator_forcerange  # a view: `step` writes the torque-speed limits

    # --- episode -------------------------------------------------------------------------------

    def reset(self, seed: int | None = None) -> RobotState:
        """Put the robot in the nominal stand at the origin, feet on the terrain, at rest."""
        if seed is not None:
            self.rng = np.random.default_rng(seed)
        mujoco.mj_resetData(self.model, self.data)
        mujoco.mj_kinematics(self.model, self.data)  # terrain geom poses, for the height query
        self.data.qpos[:3] = [0.0, 0.0, self.terrain_height(0.0, 0.0) + digit.PELVIS_HEIGHT_STAND_M + 0.002]
        self.data.qpos[3:7] = [1.0, 0.0, 0.0, 0.0]
        self.data.qpos[self.joint_map.q] = digit.Q_STAND
        self.data.ctrl[:] = self._ctrl(JointCommand.hold(digit.Q_STAND))
        self._push_substeps_left = 0
        mujoco.mj_forward(self.model, self.data)
        return self.state()

    def step(self, command: JointCommand) -> RobotState:
        """Apply `command` for one control period and return the new state."""
        if not isinstance(command, JointCommand):
            raise ConfigError(f"step expects a JointCommand, got {type(command).__name__}")
        n = self.config.substeps
        limit = JOINT_LINE.limit(self.data.qvel[self.joint_map.v])
        self._forcerange[:, 0], self._forcerange[:, 1] = -limit, limit
        if self._delay_substeps:
            self._advance(self._delay_substeps)  # the previous command is still in effect
        self.data.ctrl[:] = self._ctrl(command)
        self._advance(n - self._delay_substeps)
        if self._viewer is not None:
            self._viewer.sync()
        return self.state()

    def push(self, force_xyz_n, duration_s: float) -> None:
        """Apply a world-frame force [N] at the pelvis origin for `duration_s` from now."""
        force = np.asarray(force_xyz_n, dtype=float)
        if force.shape != (3,) or not np.all(np.isfinite(force)):
            raise ConfigError(f"push force must be a finite (3,) vector [N], got {force_xyz_n}")
        if not (np.isfinite(duration_s) and duration_s >= 0):
            raise ConfigError(f"push duration_s must be >= 0, got {duration_s}")
        self._push_substeps_left = int(round(duration_s / self.config.timestep_s))
        self.data.xfrc_applied[self._pelvis, :3] = force
        self.data.xfrc_applied[self._pelvis, 3:] = np.cross(self.data.xpos[self._pelvis] - self.data.xipos[self._pelvis], force)

    def _advance(self, nsub: int) -> None:
        """Advance `nsub` physics steps, ending a push at its exact physics step."""
        while nsub > 0:
            chunk = min(nsub, self._push_substeps_left) if self._push_substeps_left else nsub
            mujoco.mj_step(self.model, self.data, nstep=chunk)
            nsub -= chunk
            if self._push_substeps_left:
                self._push_substeps_left -= chunk
                if self._push_substeps_left == 0:
                    self.data.xfrc_applied[self._pelvis] = 0.0

    def _ctrl(self, command: JointCommand) -> np.ndarray:
        return command.tau_ff + self._kp * command.q_des + self._kd * command.qd_des

    # --- state -----------------------------------------------------------------------------------

    def state(self) -> RobotState:
        """The current `RobotState` (world-frame velocities)."""
        d = self.data
        qpos, qvel = d.qpos.copy(), d.qvel.copy()
        force = d.sensordata[self._touch_adr]
        return RobotState(
            time=d.time, base_pos=qpos[:3], base_quat=qpos[3:7], base_linvel=qvel[:3],
            base_angvel=d.xmat[self._pelvis].reshape(3, 3) @ qvel[3:6],
            q=qpos[self.joint_map.q], qd=qvel[self.joint_map.v],
            contact=force > self.config.contact_threshold_n, foot_force=force, tau=d.actuator_force.copy(),
        )

    def set_state(self, state: RobotState) -> None:
        """Put the simulation in `state` (positions, velocities, time)."""
        d = self.data
        d.qpos[:3], d.qpos[3:7] = state.base_pos, state.base_quat / np.linalg.norm(state.base_quat)
        d.qpos[self.joint_map.q] = state.q
        mujoco.mj_kinematics(self.model, d)
        d.qvel[:3] = state.base_linvel
        d.qvel[3:6] = d.xmat[self._pelvis].reshape(3, 3).T @ state.base_angvel
        d.qvel[self.joint_map.v] = state.qd
        d.time = state.time
        mujoco.mj_forward(self.model, d)

    def com_state(self) -> tuple[np.ndarray, np.ndarray]:
        """The whole robot's CoM position [m] and linear velocity [m/s], world frame."""
        mujoco.mj_subtreeVel(self.model, self.data)
        return self.data.subtree_com[self._pelvis].copy(), self.data.subtree_linvel[self._pelvis].copy()

    def momentum_about(self, point: np.ndarray) -> tuple[tuple[float, float, float], tuple[float, float, float],
                                                          tuple[float, float, float]]:
        """The whole robot's CoM minus a world point [m], CoM velocity [m/s] and angular momentum about the point,
        L_c + m (c - p) x v [kg m^2/s], world axes, as float triples (`PinRobot.momentum_about`'s form)."""
        com, velocity = self.com_state()  # (mj_subtreeVel also fills subtree_angmom: about the CoM)
        (rx, ry, rz), (vx, vy, vz) = (com - point).tolist(), velocity.tolist()
        kx, ky, kz = self.data.subtree_angmom[self._pelvis].tolist()
        m = float(self.model.body_subtreemass[self._pelvis])
        return ((rx, ry, rz), (vx, vy, vz),
                (kx + m * (ry * vz - rz * vy), ky + m * (rz * vx - rx * vz), kz + m * (rx * vy - ry * vx)))

    def sole_position(self, foot: int) -> np.ndarray:
        """(3,) centre of the sole of `foot` (0 left, 1 right): its box centre, half the box's height down the
        foot's z axis, world [m]."""
        geom = self._foot_geoms[foot]
        return self.data.geom_xpos[geom] - (0.5 * digit.FOOT_SIZE_M[2]) * self.data.geom_xmat[geom, 2::3]

    @property
    def fallen(self) -> bool:
        """Pelvis too low above the terrain, or a body part other than a foot touching the ground."""
        pelvis = self.data.xpos[self._pelvis]
        if pelvis[2] - self.terrain_height(pelvis[0], pelvis[1]) < self.config.fall_height_m:
            return True
        ncon = self.data.ncon
        if ncon == 0:
            return False
        geoms = self.data.contact.geom[:ncon]
        return bool(np.any((self._is_terrain[geoms[:, 0]] & self._is_body_part[geoms[:, 1]])
                           | (self._is_terrain[geoms[:, 1]] & self._is_body_part[geoms[:, 0]])))

    def terrain_height(self, x: float, y: float) -> float:
        """Height of the terrain surface at (x, y) [m], by a vertical ray against the terrain geoms (a ray
        exactly on the shared edge of two terrain boxes misses both: it is cast again 1 um further)."""
        top = 50.0
        for dx in (0.0, 1e-6):
            distance = mujoco.mj_ray(self.model, self.data, np.array([x + dx, y, top]), np.array([0.0, 0.0, -1.0]),
                                     self._ray_groups, 1, -1, self._ray_geom)
            if distance >= 0:
                return top - distance
        raise MbcError(f"no terrain below ({x:.2f}, {y:.2f})")

    # --- randomization hooks -----------------------------------------------------------------------

    def set_domain(self, params: DomainParams) -> None:
        """Set friction, link masses, motor strength, actuator delay, CoM offset and joint friction (from nominal)."""
        m, nominal = self.model, self._nominal
        scale = np.broadcast_to(np.asarray(params.mass_scale, dtype=float), (m.nbody,))
        m.body_mass[:] = nominal["body_mass"] * scale
        m.body_inertia[:] = nominal["body_inertia"] * scale[:, None]
        m.body_ipos[:] = nominal["body_ipos"]
        m.body_ipos[self._pelvis] += params.com_offset_m
        m.geom_friction[:] = nominal["geom_friction"]
        m.geom_friction[:, 0] *= params.friction  # the feet and ground are 1.0: a low-friction board stays lower
        m.dof_frictionloss[:] = nominal["dof_frictionloss"] * params.joint_friction_scale
        self._strength = np.broadcast_to(np.asarray(params.motor_strength, dtype=float), (digit.NUM_JOINTS,)).copy()
        delay = int(round(params.delay_s / self.config.timestep_s))
        if delay >= self.config.substeps:
            raise ConfigError(f"delay_s must be below the control period {self.config.control_dt_s} s, got {params.delay_s}")
        self._delay_substeps = delay
        self._set_gains(self._kp, self._kd)
        mujoco.mj_setConst(self.model, self.data)
        self.domain = params

    def set_gains(self, kp: np.ndarray, kd: np.ndarray) -> None:
        """Change the joint PD gains (e.g. Kp = Kd = 0 for pure torque control)."""
        self.config = dataclasses.replace(self.config, kp=np.asarray(kp, float), kd=np.asarray(kd, float))
        self._set_gains(self.config.kp, self.config.kd)

    def _set_gains(self, kp: np.ndarray, kd: np.ndarray) -> None:
        self._kp, self._kd = np.array(kp, dtype=float), np.array(kd, dtype=float)
        self.model.actuator_gainprm[:, 0] = self._strength
        self.model.actuator_biasprm[:, 1] = -self._strength * self._kp
        self.model.actuator_biasprm[:, 2] = -self._strength * self._kd

    @property
    def kp(self) -> np.ndarray:
        return self._kp.copy()

    @property
    def kd(self) -> np.ndarray:
        return self._kd.copy()

    # --- viewer ----------------------------------------------------------------------------------

    def _open_viewer(self):
        try:
            import mujoco.viewer

            return mujoco.viewer.launch_passive(self.model, self.data)
        except Exception as exc:  # no display, no GL: say so clearly
            raise MbcError(f"could not open the MuJoCo viewer ({exc}); run headless with viewer=False") from exc

    def close(self) -> None:
        """Close the viewer, if any."""
        if self._viewer is not None:
            self._viewer.close()
            self._viewer = None


DigitSim.robots[DigitSim.robot_name] = DigitSim
