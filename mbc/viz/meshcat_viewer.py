"""Meshcat browser viewer: the robot, the terrain, footsteps, the CoM and its ALIP state, the swing
reference, coloured by model-assumption violation; live, recorded and exported as HTML.

    viewer = MeshcatViewer(sim)           # starts a meshcat server on 127.0.0.1 only, and prints its URL
    run_episode(sim, controller, command, 10.0, on_tick=viewer.on_tick(controller))
    viewer.export_html("walk.html")       # replays the recording, opens without a server
"""

from __future__ import annotations

import atexit
from dataclasses import dataclass, field
from pathlib import Path

import meshcat
import meshcat.geometry as g
import meshcat.transformations as tf
import mujoco
import numpy as np
import pinocchio as pin

from mbc.assumptions import MAR_W0, mar_weight
from mbc.pin_robot import PinRobot
from mbc.sim import DigitSim
from mbc.sim.terrain import TERRAIN_GROUP
from mbc.types import RobotState
from mbc.viz.meshcat_server import start_server
from robots.digit import constants as digit

_BODY = 0x5a6478
_FOOT = 0xcc8033
_TERRAIN = 0x8c998c


def _segment_transform(start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Pose of a meshcat cylinder (axis y, centred) spanning start -> end."""
    axis = end - start
    length = np.linalg.norm(axis)
    y = axis / length
    x = np.cross(y, [0.0, 0.0, 1.0]) if abs(y[2]) < 0.99 else np.array([1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    pose = np.eye(4)
    pose[:3, :3] = np.c_[x, y, np.cross(x, y)]
    pose[:3, 3] = (start + end) / 2
    return pose


def violation_colour(com_vertical_velocity_mps: float) -> int:
    """Green where the ALIP assumption holds (MAR weight w0), red where it is violated (weight 0)."""
    violated = 1.0 - float(mar_weight(com_vertical_velocity_mps)) / MAR_W0
    red, green = int(255 * violated), int(255 * (1 - violated))
    return (red << 16) | (green << 8) | 40


@dataclass
class _Frame:
    """One drawn tick: transforms and animatable properties ((path, property) -> (three.js type, value))."""

    time_s: float
    poses: dict[str, np.ndarray] = field(default_factory=dict)
    properties: dict[tuple[str, str], tuple[str, object]] = field(default_factory=dict)


class MeshcatViewer:
    """Draws `DigitSim` states and controller diagnostics in meshcat; records for replay."""

    def __init__(self, sim: DigitSim | None = None, zmq_url: str | None = None) -> None:
        """Connect to the meshcat server at `zmq_url`, or start one on loopback that ends with this program."""
        self._server = None
        if zmq_url is None:
            self._server, zmq_url, _ = start_server()
            atexit.register(self.close)
        self.vis = meshcat.Visualizer(zmq_url=zmq_url)
        print(f"meshcat viewer at {self.url}")
        self.robot = PinRobot()
        self._joint_ids = {name: self.robot.model.getJointId(name) for name in digit.JOINT_NAMES}
        self._frames: list[_Frame] = []
        self._footsteps = 0
        self._touchdowns: list[np.ndarray] = []  # stance soles at touchdowns not yet drawn
        self._draw_robot()
        self._draw_markers()
        # an oblique view from the front left (the camera frame is y-up); the grid would stand still
        # under the walking robot (the world moves, see `update`), the terrain shows the ground
        self.vis["/Cameras/default/rotated/<object>"].set_property("position", [2.2, 1.0, 2.2])
        self.vis["/Grid"].set_property("visible", False)
        if sim is not None:
            self.draw_terrain(sim.model)

    @property
    def url(self) -> str:
        return self.vis.url()

    # --- scene -------------------------------------------------------------------------------------

    def _draw_robot(self) -> None:
        material = g.MeshLambertMaterial(color=_BODY)
        self.vis["robot/pelvis/box"].set_object(g.Box([0.2, 0.3, 0.45]), material)
        self.vis["robot/pelvis/box"].set_transform(tf.translation_matrix([0, 0, 0.2]))
        for side in digit.SIDES:
            links = digit.leg_links(side)
            thigh, shank = np.array(links[3].offset_m), np.array(links[4].offset_m)
            for name, end, radius in (("hip_pitch", thigh, 0.05), ("knee", shank, 0.035)):
                path = f"robot/{side}_{name}/segment"
                self.vis[path].set_object(g.Cylinder(float(np.linalg.norm(end)), radius), material)
                self.vis[path].set_transform(_segment_transform(np.zeros(3), end))
            foot = f"robot/{side}_ankle_roll/foot"
            centre = digit.FOOT_BOX_CENTER_M if side == "left" else digit.mirror_y(digit.FOOT_BOX_CENTER_M)
            self.vis[foot].set_object(g.Box(list(digit.FOOT_SIZE_M)), g.MeshLambertMaterial(color=_FOOT))
            self.vis[foot].set_transform(tf.translation_matrix(centre))
            self.vis[f"robot/{side}_hip_roll/joint"].set_object(g.Sphere(0.05), material)

    def _draw_markers(self) -> None:
        self.vis["markers/com"].set_object(g.Sphere(0.04), g.MeshLambertMaterial(color=0x28ff28))
        self.vis["markers/target"].set_object(g.Cylinder(0.005, 0.06), g.MeshLambertMaterial(color=0x3366ff, opacity=0.8))
        self.vis["markers/swing"].set_object(g.Sphere(0.02), g.MeshLambertMaterial(color=0xffcc00))
        # the stance-contact-to-CoM segment: a unit cylinder along y, scaled to its length each frame
        self.vis["markers/alip"].set_object(g.Cylinder(1.0, 0.008), g.MeshLambertMaterial(color=0x28ff28))

    def draw_terrain(self, model: mujoco.MjModel) -> None:
        """Draw the terrain geoms of a compiled `DigitSim` model (planes, boxes, heightfields)."""
        material = g.MeshLambertMaterial(color=_TERRAIN)
        data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)
        for geom in np.flatnonzero(model.geom_group == TERRAIN_GROUP):
            pose = np.eye(4)
            pose[:3, :3] = data.geom_xmat[geom].reshape(3, 3)
            pose[:3, 3] = data.geom_xpos[geom]
            kind, size, path = model.geom_type[geom], model.geom_size[geom], f"terrain/{geom}"
            if kind == mujoco.mjtGeom.mjGEOM_PLANE:
                self.vis[path].set_object(g.Box([40.0, 40.0, 0.02]), material)
                pose = pose @ tf.translation_matrix([0, 0, -0.01])
            elif kind == mujoco.mjtGeom.mjGEOM_BOX:
                self.vis[path].set_object(g.Box(list(2 * size)), material)
            elif kind == mujoco.mjtGeom.mjGEOM_HFIELD:
                self.vis[path].set_object(self._heightfield_mesh(model, model.geom_dataid[geom]), material)
            else:
                continue
            self.vis[path].set_transform(pose)

    @staticmethod
    def _heightfield_mesh(model: mujoco.MjModel, hfield: int) -> g.TriangularMeshGeometry:
        rows, cols = model.hfield_nrow[hfield], model.hfield_ncol[hfield]
        size_x, size_y, size_z, _ = model.hfield_size[hfield]
        adr = model.hfield_adr[hfield]
        heights = model.hfield_data[adr:adr + rows * cols].reshape(rows, cols) * size_z
        xs, ys = np.linspace(-size_x, size_x, cols), np.linspace(-size_y, size_y, rows)
        grid_x, grid_y = np.meshgrid(xs, ys)
        vertices = np.c_[grid_x.ravel(), grid_y.ravel(), heights.ravel()]
        index = np.arange(rows * cols).reshape(rows, cols)
        a, b, c_, d = index[:-1, :-1].ravel(), index[:-1, 1:].ravel(), index[1:, :-1].ravel(), index[1:, 1:].ravel()
        faces = np.r_[np.c_[a, b, d], np.c_[a, d, c_]]
        return g.TriangularMeshGeometry(vertices, faces)

    # --- updates ---------------------------------------------------------------------------------

    def _link_poses(self, state: RobotState) -> dict[str, np.ndarray]:
        self.robot.update(state)
        data = self.robot.data
        poses = {"robot/pelvis": pin.XYZQUATToSE3(np.r_[state.base_pos, state.base_quat[1:], state.base_quat[0]]).homogeneous}
        for name, joint in self._joint_ids.items():
            poses[f"robot/{name}"] = data.oMi[joint].homogeneous
        return poses

    def update(self, state: RobotState, diagnostics=None) -> None:
        """Draw `state` and, if given, the controller's diagnostics of that tick; record the frame.

        The camera follows the robot by moving the world under it (meshcat's orbit controls keep aiming
        at the origin, so moving the camera itself loses the robot)."""
        frame = _Frame(state.time)
        frame.poses = self._link_poses(state)
        x, y, z = state.base_pos.tolist()
        frame.poses["/meshcat"] = tf.translation_matrix([-x, -y, -(z - digit.PELVIS_HEIGHT_STAND_M)])
        com = self.robot.com
        frame.poses["markers/com"] = tf.translation_matrix(com)
        if diagnostics is not None and diagnostics.alip is not None:
            colour = violation_colour(diagnostics.assumptions.com_vertical_velocity_mps)
            rgb = [((colour >> shift) & 255) / 255 for shift in (16, 8, 0)]
            for path in ("markers/com", "markers/alip"):
                frame.properties[(path, "material.color")] = ("color", rgb)
            frame.poses["markers/target"] = tf.translation_matrix(diagnostics.foot_target_world) @ tf.rotation_matrix(
                np.pi / 2, [1, 0, 0])
            frame.poses["markers/swing"] = tf.translation_matrix(diagnostics.swing_reference_world)
            contact = diagnostics.stance_sole_world
            frame.poses["markers/alip"] = _segment_transform(contact, com)
            frame.properties[("markers/alip", "scale")] = ("vector3", [1.0, float(np.linalg.norm(com - contact)), 1.0])
            if diagnostics.touchdown:
                self._touchdowns.append(contact)
        for contact in self._touchdowns:  # this tick's and those of the ticks not drawn since the last frame
            frame.properties[(self._add_footstep(contact), "visible")] = ("boolean", True)
        self._touchdowns.clear()
        self._draw(frame)
        self._frames.append(frame)

    def _draw(self, frame: _Frame) -> None:
        for path, pose in frame.poses.items():
            self.vis[path].set_transform(pose)
        for (path, name), (_, value) in frame.properties.items():
            if name == "material.color":
                self.vis[path].set_property("color", [*value, 1.0])
            elif name == "scale":  # live, the scale travels in the transform matrix
                self.vis[path].set_transform(frame.poses[path] @ np.diag([*value, 1.0]))
            else:
                self.vis[path].set_property(name, value)

    def _add_footstep(self, position: np.ndarray) -> str:
        """Draw a footprint at `position`; returns its path."""
        path = f"footsteps/{self._footsteps}"
        self.vis[path].set_object(g.Box([digit.FOOT_SIZE_M[0], digit.FOOT_SIZE_M[1], 0.004]),
                                  g.MeshLambertMaterial(color=0x2255aa, opacity=0.6))
        self.vis[path].set_transform(tf.translation_matrix(position + [0, 0, 0.002]))
        self._footsteps += 1
        return path

    def on_tick(self, controller=None, every: int = 4):
        """A `run_episode(on_tick=...)` callback drawing every `every`-th tick (with diagnostics)."""
        counter = iter(range(1 << 62))

        def callback(state: RobotState, _action) -> None:
            diagnostics = getattr(controller, "last_diagnostics", None)
            if next(counter) % every == 0:
                self.update(state, diagnostics)
            elif diagnostics is not None and diagnostics.touchdown and diagnostics.alip is not None:
                self._touchdowns.append(diagnostics.stance_sole_world)  # drawn with the next frame

        return callback

    # --- recording -------------------------------------------------------------------------------

    def replay(self, fps: int = 30) -> None:
        """Load the recorded frames as a meshcat animation (play it from the viewer's controls): the
        robot, the camera's follow, the markers with their colour, the stance-to-CoM segment, and each
        footprint appearing at its touchdown."""
        if not self._frames:
            return
        animation = meshcat.animation.Animation(default_framerate=fps)
        start = self._frames[0].time_s
        with animation.at_frame(self.vis, 0) as first:
            for k in range(self._footsteps):
                first[f"footsteps/{k}"].set_property("visible", "boolean", False)
        for frame in self._frames:
            with animation.at_frame(self.vis, int(round((frame.time_s - start) * fps))) as keyframe:
                for path, pose in frame.poses.items():
                    keyframe[path].set_transform(pose)
                for (path, name), (jstype, value) in frame.properties.items():
                    keyframe[path].set_property(name, jstype, value)
        self.vis.set_animation(animation, play=True, repetitions=1)

    def export_html(self, path: str | Path) -> Path:
        """Write a self-contained HTML file of the scene with the recording as an animation."""
        self.replay()
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(self.vis.static_html())
        return path

    def close(self) -> None:
        """Close the connection and stop the meshcat server this viewer started (idempotent)."""
        self.vis.window.zmq_socket.close(linger=0)
        if self._server is not None:
            self._server.terminate()
            self._server.wait(timeout=10)
            self._server = None
