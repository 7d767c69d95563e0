"""Terrains by name, with validated parameters, added to a MuJoCo spec.

* `flat`: an infinite plane.
* `slope`: flat run-up, then an incline of `angle_deg` (negative: downhill) over `length_m`
  horizontally, then a plateau. Built from boxes, so each face is exactly planar.
* `uneven`: a heightfield with heights in [-amplitude, amplitude], smooth at `wavelength_m`,
  flat near the start.
* `stairs`: `num_steps` steps of `step_height` up, a landing, and as many down.
* `board`: flat ground and a low-friction board across the path, `height_m` thick (a step up and down):
  the paper's step-and-slip hardware test (a whiteboard strewn with poppy seeds or oil).
* `soft`: yielding ground (sand): a plane whose contacts are soft (MuJoCo's solref and solimp), so the
  feet sink into it under load.
* `course`: `num_levels` levels of increasing difficulty d = k / num_levels along +x: the robustness
  course. Each level of the `mixed` kind is an uneven patch (d * max_amplitude), a slope up and down
  (d * max_slope_deg) and three steps up and down (d * max_step_height); the `slope` and `uneven`
  kinds keep only their part (the paper's sloped and uneven courses). `Course.level_starts_m` says
  where each level begins.

The robot starts at the origin, facing +x; every terrain is flat (z = 0) within
`START_CLEARANCE_M` of it. Terrain geoms are in `TERRAIN_GROUP`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import mujoco
import numpy as np

from mbc.errors import ConfigError
from mbc.robot import CONTACT_FRICTION, GROUND_CONAFFINITY, GROUND_CONTYPE

TERRAIN_GROUP = 3
START_CLEARANCE_M = 0.8
_X_BACK_M, _X_FRONT_M, _HALF_WIDTH_M = -20.0, 80.0, 25.0
_BOX_THICKNESS_M = 1.0
_RGBA = (0.55, 0.6, 0.55, 1.0)
MAX_STEP_HEIGHT_M = 0.3
"""Largest riser or bump height a terrain accepts: beyond what Digit's legs can step (hip to sole 0.9 m) [m]."""


def _require(condition: bool, message: str) -> None:
    if not condition:
        raise ConfigError(message)


@dataclass(frozen=True)
class Flat:
    """An infinite plane at z = 0."""


@dataclass(frozen=True)
class Slope:
    """Flat run-up, an incline, a plateau."""

    angle_deg: float = 10.0
    """Incline angle [deg]; positive climbs in +x, negative descends. |angle| < 45."""
    run_up_m: float = 2.0
    """Flat distance from the origin to the foot of the incline [m]."""
    length_m: float = 5.0
    """Horizontal length of the incline [m]."""

    def __post_init__(self) -> None:
        _require(abs(self.angle_deg) < 45.0, f"slope angle_deg must be in (-45, 45), got {self.angle_deg}")
        _require(self.run_up_m >= START_CLEARANCE_M, f"slope run_up_m must be >= {START_CLEARANCE_M}, got {self.run_up_m}")
        _require(self.length_m > 0, f"slope length_m must be positive, got {self.length_m}")


@dataclass(frozen=True)
class Uneven:
    """Random smooth heightfield."""

    amplitude: float = 0.02
    """Largest height deviation from z = 0 [m]."""
    wavelength_m: float = 0.4
    """Spacing of the random control heights (the bump size) [m]."""
    extent_m: float = 15.0
    """Half-size of the square field around the origin [m]."""

    def __post_init__(self) -> None:
        _require(0 <= self.amplitude <= MAX_STEP_HEIGHT_M,
                 f"uneven amplitude must be in [0, {MAX_STEP_HEIGHT_M}] m, got {self.amplitude}")
        _require(self.wavelength_m > 0, f"uneven wavelength_m must be positive, got {self.wavelength_m}")
        _require(self.extent_m > START_CLEARANCE_M, f"uneven extent_m must exceed {START_CLEARANCE_M}, got {self.extent_m}")


@dataclass(frozen=True)
class Stairs:
    """Steps up, a landing, steps down."""

    step_height: float = 0.1
    """Riser height [m]."""
    step_depth: float = 0.35
    """Tread depth [m]."""
    num_steps: int = 5
    run_up_m: float = 1.5
    landing_m: float = 2.0

    def __post_init__(self) -> None:
        _require(0 <= self.step_height <= MAX_STEP_HEIGHT_M,
                 f"stairs step_height must be in [0, {MAX_STEP_HEIGHT_M}] m, got {self.step_height}")
        _require(self.step_depth > 0, f"stairs step_depth must be positive, got {self.step_depth}")
        _require(self.num_steps >= 1, f"stairs num_steps must be >= 1, got {self.num_steps}")
        _require(self.run_up_m >= START_CLEARANCE_M, f"stairs run_up_m must be >= {START_CLEARANCE_M}")


@dataclass(frozen=True)
class Board:
    """Flat ground with a slippery board to step onto and walk across."""

    friction: float = 0.15
    """Sliding friction of the board against the feet (dry whiteboard about 0.3; with seeds or oil 0.1-0.2)."""
    height_m: float = 0.02
    """Thickness of the board: the step up onto it [m]."""
    run_up_m: float = 1.5
    """Flat distance from the origin to the board's near edge [m]."""
    length_m: float = 1.5
    """Length of the board along +x [m]."""
    width_m: float = 1.2
    """Width of the board, centred on the path [m]."""

    def __post_init__(self) -> None:
        _require(0 < self.friction <= 2.0, f"board friction must be in (0, 2], got {self.friction}")
        _require(0 < self.height_m <= MAX_STEP_HEIGHT_M, f"board height_m must be in (0, {MAX_STEP_HEIGHT_M}] m")
        _require(self.run_up_m >= START_CLEARANCE_M, f"board run_up_m must be >= {START_CLEARANCE_M}, got {self.run_up_m}")
        _require(self.length_m > 0 and self.width_m > 0, "board length_m and width_m must be positive")


@dataclass(frozen=True)
class Soft:
    """Yielding ground: its contacts follow MuJoCo's soft-constraint model with a slow time constant and a
    wide impedance ramp, so that a loaded foot sinks about 3 cm (`tests/test_sim.py` measures it)."""

    timeconst_s: float = 0.05
    """solref time constant of the ground's contacts (MuJoCo's default 0.02: stiff) [s]."""
    dampratio: float = 1.0
    """solref damping ratio."""
    width_m: float = 0.04
    """solimp width: the penetration over which the impedance rises from 0.1 to 0.9 [m]."""

    def __post_init__(self) -> None:
        _require(0.004 <= self.timeconst_s <= 1.0, f"soft timeconst_s must be in [0.004, 1] s, got {self.timeconst_s}")
        _require(self.dampratio > 0, f"soft dampratio must be positive, got {self.dampratio}")
        _require(0 < self.width_m <= 0.2, f"soft width_m must be in (0, 0.2] m, got {self.width_m}")


COURSE_KINDS = ("mixed", "slope", "uneven")
_PATCH_M, _SLOPE_M, _FLAT_M = 3.0, 2.5, 1.0
_PATCH_HALF_WIDTH_M = 10.0
"""Half-width of a course's bumpy patches [m]; beyond them lies the flat floor of the patch's pit."""
_COURSE_STEPS, _COURSE_TREAD_M = 3, 0.35


@dataclass(frozen=True)
class Course:
    """Levels of increasing difficulty along +x."""

    num_levels: int = 5
    max_slope_deg: float = 12.0
    max_amplitude: float = 0.04
    max_step_height: float = 0.08
    run_up_m: float = 2.0
    kind: str = "mixed"
    """'mixed' (bumps, a slope, steps per level), 'slope' (a slope up and down per level) or 'uneven'."""

    def __post_init__(self) -> None:
        _require(self.kind in COURSE_KINDS, f"course kind must be one of {list(COURSE_KINDS)}, got {self.kind!r}")
        _require(self.num_levels >= 1, f"course num_levels must be >= 1, got {self.num_levels}")
        _require(0 <= self.max_slope_deg < 45, f"course max_slope_deg must be in [0, 45), got {self.max_slope_deg}")
        _require(self.max_amplitude >= 0, f"course max_amplitude must be >= 0, got {self.max_amplitude}")
        _require(0 <= self.max_step_height <= MAX_STEP_HEIGHT_M,
                 f"course max_step_height must be in [0, {MAX_STEP_HEIGHT_M}] m, got {self.max_step_height}")
        _require(self.run_up_m >= START_CLEARANCE_M, f"course run_up_m must be >= {START_CLEARANCE_M}")

    @property
    def has_patches(self) -> bool:
        return self.kind in ("mixed", "uneven")

    @property
    def has_slopes(self) -> bool:
        return self.kind in ("mixed", "slope")

    @property
    def level_length_m(self) -> float:
        """Length of one level along x [m]."""
        patch = _PATCH_M + _FLAT_M if self.has_patches else 0.0
        slope = 2 * (_SLOPE_M + _FLAT_M) if self.has_slopes else 0.0
        stairs = (2 * _COURSE_STEPS - 1) * _COURSE_TREAD_M + _FLAT_M + _FLAT_M if self.kind == "mixed" else 0.0
        return patch + slope + stairs

    def level_starts_m(self) -> np.ndarray:
        """(num_levels + 1,) x where each level begins, and where the last one ends [m]."""
        return self.run_up_m + self.level_length_m * np.arange(self.num_levels + 1)


TERRAINS: dict[str, type] = {"flat": Flat, "slope": Slope, "uneven": Uneven, "stairs": Stairs, "board": Board,
                             "soft": Soft, "course": Course}
TerrainConfig = Flat | Slope | Uneven | Stairs | Board | Soft | Course


def make_terrain(name: str, **params) -> TerrainConfig:
    """The terrain config `name` with `params`; unknown names or parameters raise `ConfigError`."""
    if name not in TERRAINS:
        raise ConfigError(f"unknown terrain {name!r}; valid terrains: {sorted(TERRAINS)}")
    cls = TERRAINS[name]
    valid = [f.name for f in dataclasses.fields(cls)]
    unknown = sorted(set(params) - set(valid))
    if unknown:
        raise ConfigError(f"terrain {name!r} has no parameter(s) {unknown}; valid parameters: {valid}")
    return cls(**params)


# --- building -------------------------------------------------------------------------------------


def add_terrain(spec: mujoco.MjSpec, terrain: TerrainConfig, rng: np.random.Generator) -> None:
    """Add the terrain's geoms (and heightfields) to `spec`'s world body."""
    if isinstance(terrain, Flat):
        _ground(spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05]))
    elif isinstance(terrain, Slope):
        rise = terrain.length_m * np.tan(np.deg2rad(terrain.angle_deg))
        x1 = terrain.run_up_m + terrain.length_m
        _add_profile(spec, [(_X_BACK_M, 0.0), (terrain.run_up_m, 0.0), (x1, rise), (_X_FRONT_M, rise)])
    elif isinstance(terrain, Uneven):
        heights = _smooth_noise(rng, terrain.amplitude, terrain.wavelength_m, 2 * terrain.extent_m, 2 * terrain.extent_m)
        xs, ys = _grid(2 * terrain.extent_m, 2 * terrain.extent_m, heights.shape)
        heights *= _ramp(np.hypot(*np.meshgrid(xs, ys)) - START_CLEARANCE_M, 0.5)
        _add_heightfield(spec, "uneven", heights, center=(0.0, 0.0, 0.0), size_xy=(terrain.extent_m, terrain.extent_m))
    elif isinstance(terrain, Stairs):
        points = [(_X_BACK_M, 0.0)]
        _stairs(points, terrain.run_up_m, terrain.step_height, terrain.step_depth, terrain.num_steps, terrain.landing_m)
        points.append((_X_FRONT_M, points[-1][1]))
        _add_profile(spec, points)
    elif isinstance(terrain, Board):
        _ground(spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05]))
        centre = [terrain.run_up_m + terrain.length_m / 2, 0.0, terrain.height_m / 2]
        board = spec.worldbody.add_geom(
            name="board", type=mujoco.mjtGeom.mjGEOM_BOX, pos=centre,
            size=[terrain.length_m / 2, terrain.width_m / 2, terrain.height_m / 2])
        _ground(board)
        board.friction = (terrain.friction, *CONTACT_FRICTION[1:])
        board.priority = 1  # its friction, not the max of the pair (the feet's 1.0), governs its contacts
        board.rgba = (0.92, 0.92, 0.95, 1.0)
    elif isinstance(terrain, Soft):
        ground = spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05])
        _ground(ground)
        ground.solref = (terrain.timeconst_s, terrain.dampratio)
        ground.solimp = (0.1, 0.9, terrain.width_m, 0.5, 2.0)
        ground.priority = 1  # its solref and solimp, not a mix with the feet's, govern its contacts
        ground.rgba = (0.85, 0.75, 0.5, 1.0)
    elif isinstance(terrain, Course):
        _add_course(spec, terrain, rng)
    else:
        raise ConfigError(f"not a terrain config: {terrain!r}; valid terrains: {sorted(TERRAINS)}")


def _ground(geom) -> None:
    geom.contype, geom.conaffinity = GROUND_CONTYPE, GROUND_CONAFFINITY
    geom.group = TERRAIN_GROUP
    geom.rgba = _RGBA
    geom.friction = CONTACT_FRICTION


def _add_profile(spec: mujoco.MjSpec, points: list[tuple[float, float]]) -> None:
    """One box per non-vertical segment of the (x, z) polyline, its top face on the segment."""
    for i, ((x0, z0), (x1, z1)) in enumerate(zip(points[:-1], points[1:])):
        if x1 <= x0:
            continue  # a vertical riser: the neighbouring boxes make it
        length = np.hypot(x1 - x0, z1 - z0)
        pitch = -np.arctan2(z1 - z0, x1 - x0)  # rotation about +y
        normal = np.array([np.sin(pitch), 0.0, np.cos(pitch)])  # upward normal of the top face
        centre = np.array([(x0 + x1) / 2, 0.0, (z0 + z1) / 2]) - normal * _BOX_THICKNESS_M / 2
        _ground(spec.worldbody.add_geom(
            name=f"terrain_box_{i}", type=mujoco.mjtGeom.mjGEOM_BOX, pos=centre,
            quat=[np.cos(pitch / 2), 0.0, np.sin(pitch / 2), 0.0],
            size=[length / 2, _HALF_WIDTH_M, _BOX_THICKNESS_M / 2]))


def _stairs(points: list, x: float, height: float, depth: float, num: int, landing: float) -> float:
    """Append a flight up, a landing and a flight down starting at x; return the end x."""
    z = points[-1][1]
    points.append((x, z))
    for sign in (1, -1):
        for _ in range(num):
            z += sign * height
            points.append((x, z))
            x += depth
            points.append((x, z))
        if sign == 1:
            x += landing - depth
            points.append((x, z))
    return x


def _add_course(spec: mujoco.MjSpec, course: Course, rng: np.random.Generator) -> None:
    points = [(_X_BACK_M, 0.0)]
    for level, x in enumerate(course.level_starts_m()[:-1], start=1):
        d, z = level / course.num_levels, points[-1][1]
        points.append((x, z))
        if course.has_patches:
            amplitude = d * course.max_amplitude
            heights = _smooth_noise(rng, amplitude, 0.4, _PATCH_M, 2 * _PATCH_HALF_WIDTH_M)
            xs, _ = _grid(_PATCH_M, 2 * _PATCH_HALF_WIDTH_M, heights.shape)
            heights *= _ramp(_PATCH_M / 2 - np.abs(xs), 0.3)[None, :]
            points += [(x, z - amplitude), (x + _PATCH_M, z - amplitude), (x + _PATCH_M, z)]
            _add_heightfield(spec, f"course_{level}", heights, (x + _PATCH_M / 2, 0.0, z),
                            (_PATCH_M / 2, _PATCH_HALF_WIDTH_M))
            x += _PATCH_M + _FLAT_M
        if course.has_slopes:
            rise = _SLOPE_M * np.tan(np.deg2rad(d * course.max_slope_deg))
            points += [(x, z), (x + _SLOPE_M, z + rise), (x + _SLOPE_M + _FLAT_M, z + rise),
                       (x + 2 * _SLOPE_M + _FLAT_M, z)]
            x += 2 * (_SLOPE_M + _FLAT_M)
        if course.kind == "mixed":
            _stairs(points, x, d * course.max_step_height, _COURSE_TREAD_M, _COURSE_STEPS, _FLAT_M)
    points.append((_X_FRONT_M, points[-1][1]))
    _add_profile(spec, points)


def _grid(size_x: float, size_y: float, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Sample coordinates of a (rows = y, cols = x) field centred on 0."""
    return np.linspace(-size_x / 2, size_x / 2, shape[1]), np.linspace(-size_y / 2, size_y / 2, shape[0])


def _ramp(distance: np.ndarray, width: float) -> np.ndarray:
    """0 for distance <= 0, rising smoothly to 1 at distance >= width."""
    s = np.clip(distance / width, 0.0, 1.0)
    return s * s * (3 - 2 * s)


def _smooth_noise(rng: np.random.Generator, amplitude: float, wavelength: float, size_x: float,
                  size_y: float, resolution: float = 0.05) -> np.ndarray:
    """Heights in [-amplitude, amplitude]: uniform control points every `wavelength`, bilinear between."""
    nx, ny = int(round(size_x / resolution)) + 1, int(round(size_y / resolution)) + 1
    cx, cy = int(np.ceil(size_x / wavelength)) + 1, int(np.ceil(size_y / wavelength)) + 1
    control = rng.uniform(-amplitude, amplitude, size=(cy, cx))
    u = np.linspace(0, cx - 1, nx)
    v = np.linspace(0, cy - 1, ny)
    along_x = np.array([np.interp(u, np.arange(cx), row) for row in control])  # (cy, nx)
    return np.array([np.interp(v, np.arange(cy), col) for col in along_x.T]).T  # (ny, nx)


def _add_heightfield(spec: mujoco.MjSpec, name: str, heights: np.ndarray, center, size_xy) -> None:
    """A heightfield geom whose surface is z = center_z + heights (rows along y, columns along x)."""
    low, high = float(heights.min()), float(heights.max())
    span = max(high - low, 1e-6)
    rows, cols = heights.shape
    spec.add_hfield(name=name, size=[size_xy[0], size_xy[1], span, 0.2], nrow=rows, ncol=cols,
                    userdata=((heights - low) / span).ravel().tolist())
    _ground(spec.worldbody.add_geom(name=f"{name}_geom", type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname=name,
                                    pos=[center[0], center[1], center[2] + low]))
