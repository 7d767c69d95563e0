"""PureRL's swing-foot trajectory term: how close the swing sole is to where an ALIP foot-placement controller
would have it, computed from the robot's own state (no IK, no QP, no expert).

Each tick of a step (stance foot, phase s and step duration T from the observation's gait clock):

1. the ALIP state about the stance sole in the heading frame (`mbc.alip_state.alip_state_of`) from MuJoCo's
   CoM, velocity and angular momentum about the sole, L_p = L_c + m (c - p) x v (`DigitSim.momentum_about`);
2. the landing step of the one-step-ahead law for the command, touchdown `time_to_touchdown_s` from now
   (`AlipModel.one_step_placement` toward the periodic gait's step-end momenta `mbc.alip.GaitEndMomenta`), within
   the MBC's reach (`StepReach.clip`), on the terrain's surface there;
3. the reference sole at s: p_lift + (p_land - p_lift) b(s) with the minimum-jerk blend b (`mbc.swing.min_jerk`),
   raised by the lift-and-lower profile (`mbc.swing.swing_height`), where p_lift is the swing sole at the step's start.

    swing_foot_tracking = exp(-|p_swing - p_ref|^2 / sigma),   sigma = SIGMA_M2,

and 0 during the standing start's weight shift (both feet down, no swing).
"""

from __future__ import annotations

import numpy as np

from mbc.alip import AlipModel, GaitEndMomenta
from mbc.alip_mpc import StepReach
from mbc.alip_state import alip_state_of
from mbc.controller import AlipControllerConfig
from mbc.errors import MbcError
from mbc.geometry import rotate_z, yaw_of_quaternion
from mbc.sim import DigitSim
from mbc.swing import min_jerk, swing_height
from mbc.timing import RIGHT, GaitClock
from robots.digit import constants as digit

SIGMA_M2 = 0.01
"""sigma of the term: a 10 cm distance from the reference scores exp(-1) [m^2]."""


class SwingFootReference:
    """The reference sole of a simulator's swing foot, per tick, and the reward term from it."""

    def __init__(self, sim: DigitSim, config: AlipControllerConfig | None = None) -> None:
        self.sim = sim
        self.config = cfg = config or AlipControllerConfig()
        self.alip = AlipModel(digit.TOTAL_MASS_KG, cfg.nominal_com_height_m)
        self.momenta = GaitEndMomenta(self.alip, cfg.timing.step_duration_s, cfg.step_width_m)
        self.reach = StepReach(cfg.max_step_length_m, cfg.min_step_width_m, cfg.max_step_width_m)
        self._touchdowns, self._liftoff = -1, np.zeros(3)

    def reset(self) -> None:
        """Start an episode: the next step's liftoff is read afresh."""
        self._touchdowns = -1

    def landing(self, clock: GaitClock, command: np.ndarray, heading: float) -> np.ndarray:
        """(3,) the one-step law's landing point of the swing foot, world [m]."""
        stance_sole = self.sim.sole_position(clock.stance)
        alip = alip_state_of(*self.sim.momentum_about(stance_sole), heading)
        (x, y), (Lx, Ly) = alip.x.tolist(), alip.L.tolist()
        swing_side = 1.0 if clock.stance == RIGHT else -1.0
        Lx_des, Ly_des = self.momenta(command, swing_side)
        T, time_left = self.config.timing.step_duration_s, clock.time_to_touchdown_s
        step = self.reach.clip(self.alip.one_step_placement(x, Lx, time_left, Lx_des, T),
                               self.alip.one_step_placement(y, Ly, time_left, Ly_des, T), swing_side)
        dx, dy = rotate_z(*step, heading)
        px, py = stance_sole[0] + dx, stance_sole[1] + dy
        try:
            pz = self.sim.terrain_height(px, py)
        except MbcError:  # beyond a bounded terrain: the stance sole's height
            pz = float(stance_sole[2])
        return np.array([px, py, pz])

    def reference(self, clock: GaitClock, command: np.ndarray, base_quat: np.ndarray,
                  swing_sole: np.ndarray | None = None) -> np.ndarray | None:
        """(3,) the swing sole's reference now, world [m]; None during the weight shift. `swing_sole`: the swing
        foot's sole now, if the caller has it."""
        if clock.shifting_weight:
            return None
        if swing_sole is None:
            swing_sole = self.sim.sole_position(clock.swing)
        if clock.touchdowns != self._touchdowns:  # a new step: its swing starts where the foot is
            self._touchdowns, self._liftoff = clock.touchdowns, swing_sole.copy()
        landing = self.landing(clock, command, yaw_of_quaternion(base_quat))
        s = min(clock.phase, 1.0)
        blend, _ = min_jerk(s)
        height, _ = swing_height(s, self.config.swing, clock.step_duration_s)
        reference = self._liftoff + (landing - self._liftoff) * blend
        reference[2] += height
        return reference

    def reward(self, clock: GaitClock, command: np.ndarray, base_quat: np.ndarray) -> float:
        """exp(-|p_swing - p_ref|^2 / SIGMA_M2); 0 in the weight shift."""
        swing_sole = self.sim.sole_position(clock.swing)
        reference = self.reference(clock, command, base_quat, swing_sole)
        if reference is None:
            return 0.0
        error = swing_sole - reference
        return float(np.exp(-float(error @ error) / SIGMA_M2))

