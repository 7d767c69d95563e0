"""Curricula of the fine-tuning: terrain difficulty per environment, and the forward-velocity range.

Terrains: each environment keeps a kind (flat, uphill, downhill, uneven, stairs; environment i takes
kind i mod n) and a level, the first drawn uniformly from 0 .. `initial_max_level`; an episode that walks
`promote_m` without falling moves it one level up, one that falls before walking `demote_m` one level down,
and one that passes the last level sends its environment to a uniformly drawn level (legged_gym's rule),
so that every level stays in the batch. Level k of L has difficulty d = k / (L - 1):

    uphill    slope  +(4 + 18 d) deg       downhill  slope  -(3 + 13 d) deg
    uneven    amplitude 1 + 4 d cm         stairs    risers 2 + 10 d cm
    soft      yielding ground, contact time constant 20 + 60 d ms (the sand protocol's: 50 ms; opt-in)
    slippery  a board 1 + 2 d cm high of friction 0.5 - 0.4 d, `SLIPPERY_BOARD_M` long and wide, the protocol's run-up
              (1.5 m) ahead (the step-and-slip protocol's board: 2 cm, 0.15, near d = 0.9; opt-in)

An incline (uphill, downhill) begins at the start's flat clearance and runs `INCLINE_LENGTH_M`, and its
environments (and the slippery ones, at the step-and-slip protocol's speeds) draw their own commands
(`TerrainCurriculum.uphill_commands`, `downhill_commands`, `slippery_commands`): forward,
at speeds an incline allows, little turning, so that they spend their episodes walking its fall line. A robot
that tracked them exactly (a kinematic count) would climb 54-62% of an uphill episode and reach the crest in
54-82% of them, descend 63-70% of a downhill one and reach its foot in 60-80%; under the evaluation's geometry
and the flat-ground commands, 18% climbing (docs/design.md, "climbs kept", "inclines at speeds they allow").

Velocity: every `every_iterations`, the upper end of the forward command grows by `step_mps` if the
mean linear-velocity tracking reward of that iteration exceeds `threshold`, up to `max_mps`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from learn.config import CommandSampling
from mbc.errors import ConfigError
from mbc.sim.terrain import START_CLEARANCE_M

DEFAULT_KINDS = ("flat", "uphill", "downhill", "uneven", "stairs")
"""The kinds of every shipped fine-tuning. `soft` and `slippery` are opt-in (`--terrain-kinds`): the noise-free
fittings fall on sand from an oscillation that rigid ground never excites (docs/evaluation.md, "Why sand falls"), and
every controller, the MBC included, slides off the step-and-slip board (docs/design.md, "slippery ground")."""
INCLINE_KINDS = ("uphill", "downhill")
INCLINE_LENGTH_M = 5.0
"""Horizontal length of a curriculum incline [m] (the evaluation's): at the inclines' commands its end (an
uphill's crest, where a 20 m incline's policy fell in evaluation; a downhill's foot) is reached in 54-82% of the
20 s episodes, and four metres of promotion fit on it."""
SLIPPERY_BOARD_M = 6.0
"""Length and width of the curriculum's slippery board [m]: the protocol's 1.5 x 1.2 m board is crossed in 3-5 s at
its 0.3 m/s and left sideways by most of the flat-ground commands (turning, lateral); this one holds the four metres
of promotion, and the step down off it is trained as well as the step onto it."""


def terrain_spec(kind: str, difficulty: float) -> str:
    """The terrain string (`learn.env.parse_terrain`) of `kind` at difficulty in [0, 1]."""
    d = min(max(difficulty, 0.0), 1.0)
    incline = f"run_up_m={START_CLEARANCE_M},length_m={INCLINE_LENGTH_M}"
    specs = {"flat": "flat", "uphill": f"slope:angle_deg={4 + 18 * d:.2f},{incline}",
             "downhill": f"slope:angle_deg={-(3 + 13 * d):.2f},{incline}",
             "uneven": f"uneven:amplitude={0.01 + 0.04 * d:.4f}", "stairs": f"stairs:step_height={0.02 + 0.10 * d:.4f}",
             "soft": f"soft:timeconst_s={0.02 + 0.06 * d:.4f}",
             "slippery": f"board:friction={0.5 - 0.4 * d:.4f},height_m={0.01 + 0.02 * d:.4f},"
                         f"length_m={SLIPPERY_BOARD_M},width_m={SLIPPERY_BOARD_M}"}
    if kind not in specs:
        raise ConfigError(f"unknown terrain kind {kind!r}; valid: {list(specs)}")
    return specs[kind]


@dataclass(frozen=True)
class TerrainCurriculum:
    """Terrain kinds and levels; promotion and demotion by distance walked."""

    kinds: tuple[str, ...] = DEFAULT_KINDS
    levels: int = 10
    promote_m: float = 4.0
    """An episode that walks this far without falling promotes its environment [m]."""
    demote_m: float = 2.0
    """An episode that falls before walking this far demotes its environment [m] (legged_gym's half of the
    promotion). At 1.5 m, a fall just past an incline's edge (0.8 m from the start) kept its level, and the
    incline environments settled where 84-97% of their episodes fell (docs/design.md, "inclines at speeds
    they allow")."""
    initial_max_level: int = 5
    """Environments start at a level drawn uniformly from 0 .. this (5 of 10: climbs to 14 deg, the distilled
    policy's steepest training incline). Starting every environment at level 0 kept a fine-tuning on 4-8 deg for
    its whole budget (20 s episodes end about once per 10 iterations of 2 s, so the levels barely moved) and it
    forgot the steeper climbs it started with."""
    uphill_commands: CommandSampling = field(default_factory=lambda: CommandSampling(
        vx_mps=(0.1, 0.8), vy_mps=(-0.2, 0.2), yaw_rate_radps=(-0.2, 0.2), standing_probability=0.1,
        lateral_probability=0.2, yaw_probability=0.2, widened=False))
    """Commands of the uphill environments. The flat-ground commands kept a fine-tuning off its inclines:
    walking backward or turned away from the fall line most of the time, 5 M steps of PPF forgot the 12-16 deg
    climbs it started with (docs/evaluation.md, "PPF at 5 M steps"). Not widened by the velocity curriculum:
    widened to 1.2 m/s, 91% of the uphill episodes of a fine-tuning fell (docs/design.md, "inclines at speeds
    they allow"). 5 M-step fine-tunings turn off the fall line on these climbs and fall; neither heading commands
    nor tracking in the episode's first heading stopped it in training (docs/design.md, "heading on inclines")."""
    downhill_commands: CommandSampling = field(default_factory=lambda: CommandSampling(
        vx_mps=(0.3, 0.5), vy_mps=(-0.2, 0.2), yaw_rate_radps=(-0.2, 0.2), standing_probability=0.1,
        lateral_probability=0.2, yaw_probability=0.2, widened=False))
    """Commands of the downhill environments, slower: over the crest onto a 10 deg descent at 0.65 m/s the MBC
    and the policies fall on every start (at 0.5 none)."""
    slippery_commands: CommandSampling = field(default_factory=lambda: CommandSampling(
        vx_mps=(0.2, 0.5), vy_mps=(-0.1, 0.1), yaw_rate_radps=(-0.1, 0.1), standing_probability=0.1,
        lateral_probability=0.2, yaw_probability=0.2, widened=False))
    """Commands of the slippery environments: forward about the step-and-slip protocol's 0.3 m/s, little stepping
    sideways or turning. Under the flat-ground commands (a third of their forward range backward, away from the
    board; turns to 0.8 rad/s off it) a pilot's slippery environments stayed at levels 0-3 of 10 (friction
    0.5-0.37) over 2.56 M steps; under these, the same pilot's reached levels 6-8 (0.23-0.14; one training seed,
    docs/evaluation.md, "A second slippery-ground pilot")."""

    def __post_init__(self) -> None:
        if not self.kinds:
            raise ConfigError("the terrain curriculum needs at least one kind")
        for kind in self.kinds:
            terrain_spec(kind, 0.0)
        if self.levels < 1 or self.promote_m <= self.demote_m:
            raise ConfigError("need levels >= 1 and promote_m > demote_m")
        if not 0 <= self.initial_max_level < self.levels:
            raise ConfigError(f"initial_max_level must be in [0, levels - 1 = {self.levels - 1}], got {self.initial_max_level}")

    def spec(self, kind: str, level: int) -> str:
        return terrain_spec(kind, level / max(self.levels - 1, 1))

    def commands(self, kind: str, flat_ground: CommandSampling) -> CommandSampling:
        """The command sampling of an environment of `kind` (`flat_ground`: the task's own, off the inclines)."""
        own = {"uphill": self.uphill_commands, "downhill": self.downhill_commands, "slippery": self.slippery_commands}
        return own.get(kind, flat_ground)

    def initial_level(self, rng: np.random.Generator) -> int:
        """A starting level, uniform over 0 .. `initial_max_level`."""
        return int(rng.integers(self.initial_max_level + 1))

    def next_level(self, level: int, distance_m: float, fell: bool, rng: np.random.Generator) -> int:
        """The level after an episode that walked `distance_m` and fell or not (a random one after the last level)."""
        if not fell and distance_m >= self.promote_m:
            return level + 1 if level + 1 < self.levels else int(rng.integers(self.levels))
        if fell and distance_m < self.demote_m:
            return max(level - 1, 0)
        return level


@dataclass(frozen=True)
class VelocityCurriculum:
    """The forward command's upper end, widened while tracking is good."""

    start_mps: float = 1.0
    max_mps: float = 1.5
    step_mps: float = 0.1
    threshold: float = 0.7
    """Mean lin_vel_tracking reward (in [0, 1]) above which the range widens."""
    every_iterations: int = 12
    """The range is reconsidered every this many iterations (the policy first learns the current range)."""

    def next_max(self, current_mps: float, tracking: float, iteration: int) -> float:
        if iteration % self.every_iterations or tracking <= self.threshold:
            return current_mps
        return min(current_mps + self.step_mps, self.max_mps)
