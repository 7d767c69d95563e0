"""Meshcat viewer in a real headless Chromium, and the episode plots."""

import os
import shutil
import subprocess
import tempfile
import threading
import warnings
from pathlib import Path

import matplotlib.image
import meshcat
import numpy as np
import pytest

from mbc.controller import AlipController
from mbc.rollout import run_episode
from mbc.sim import DigitSim
from mbc.types import Command
from mbc.viz import MeshcatViewer, save_all
from mbc.viz.meshcat_server import start_server

CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                  "--disable-component-update", "--no-first-run", "--window-size=640,480"]


@pytest.fixture(scope="module")
def chromium():
    path = shutil.which("chromium")
    if path is None:
        if os.environ.get("REQUIRE_BROWSER_TESTS"):
            pytest.fail("REQUIRE_BROWSER_TESTS is set but chromium is missing")
        pytest.skip("chromium is not installed (apt-get install -y chromium); CI installs it and runs these")
    return path


def screenshot(chromium: str, url: str, out):
    """PNG of `url` as an (h, w, 3) float array. Live pages too are shot after a virtual-time budget:
    with `--timeout`, Chromium shoots at the page's load event, before the scene has come over the
    websocket (the terrain and the camera preset then look missing)."""
    subprocess.run([chromium, *CHROMIUM_FLAGS, f"--user-data-dir={tempfile.mkdtemp()}", f"--screenshot={out}",
                    "--virtual-time-budget=8000", url], check=True, capture_output=True, timeout=120)
    return matplotlib.image.imread(out)[..., :3]


def drawn_blob(image, reference) -> tuple[int, int]:
    """Pixels that differ noticeably from the reference: how many, and the height of their bounding box."""
    mask = np.abs(image - reference).max(axis=-1) > 0.1
    rows = np.flatnonzero(mask.any(axis=1))
    return int(mask.sum()), int(rows[-1] - rows[0]) if len(rows) else 0


def shows_terrain(image) -> bool:
    """The terrain (grey-green, _TERRAIN in the viewer) covers most of the lower half of the frame."""
    lower = image[image.shape[0] // 2:]
    grey_green = (np.abs(lower[..., 0] - lower[..., 2]) < 0.08) & (lower[..., 1] >= lower[..., 0]) & (lower[..., 1] > 0.2)
    return grey_green.mean() > 0.5


def scene_screenshot(chromium: str, url: str, out, empty_scene, attempts: int = 4):
    """A page once its whole scene (terrain included) has arrived: a cold browser on a busy machine can
    shoot before the websocket has delivered it (seen in CI); retried, the checks are not waived."""
    for _ in range(attempts):
        image = screenshot(chromium, url, out)
        if drawn_blob(image, empty_scene)[0] > 0 and shows_terrain(image):
            break
    return image


@pytest.fixture(scope="module")
def empty_scene(chromium, tmp_path_factory):
    server, zmq_url, web_url = start_server()
    empty = meshcat.Visualizer(zmq_url=zmq_url)
    try:
        yield screenshot(chromium, web_url, tmp_path_factory.mktemp("empty") / "empty.png")
    finally:
        empty.window.zmq_socket.close(linger=0)
        server.terminate()
        server.wait()


def test_live_viewer_and_exported_html_draw_the_robot_in_frame(chromium, empty_scene, tmp_path):
    """The robot is drawn, live and in the replay, and the camera keeps it in the frame after it has
    walked away from the origin (5 s at 0.6 m/s, turning)."""
    sim = DigitSim()
    viewer = MeshcatViewer(sim)
    try:
        assert viewer.url.startswith("http://127.0.0.1:")
        controller = AlipController.for_digit()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            walker = threading.Thread(target=run_episode, args=(sim, controller, Command(0.6, 0.0, 0.3), 5.0),
                                      kwargs={"on_tick": viewer.on_tick(controller)})
            walker.start()
            walking = scene_screenshot(chromium, viewer.url, tmp_path / "walking.png", empty_scene)
            walker.join()
        assert drawn_blob(walking, empty_scene)[0] > 1500  # the page draws while the robot walks
        # after the walk the live page stands still, so it can be compared with itself without the robot
        live = scene_screenshot(chromium, viewer.url, tmp_path / "live.png", empty_scene)
        html = viewer.export_html(tmp_path / "walk.html")
        exported = scene_screenshot(chromium, html.as_uri(), tmp_path / "exported.png", empty_scene)
        # the same pages without the robot: what remains is terrain and markers
        viewer.vis["robot"].set_property("visible", False)
        live_hidden = scene_screenshot(chromium, viewer.url, tmp_path / "live_hidden.png", empty_scene)
        hidden_html = viewer.export_html(tmp_path / "walk_hidden.html")
        exported_hidden = scene_screenshot(chromium, hidden_html.as_uri(), tmp_path / "exported_hidden.png", empty_scene)
    finally:
        viewer.close()
    for image, without_robot in ((live, live_hidden), (exported, exported_hidden)):
        assert image.std() > 0.05  # not blank
        assert drawn_blob(image, empty_scene)[0] > 1500  # differs from an empty meshcat scene
        pixels, height = drawn_blob(image, without_robot)
        assert pixels > 1500 and height > 80  # the robot: a tall, robot-sized blob
        rows, columns = np.nonzero(np.abs(image - without_robot).max(axis=-1) > 0.1)
        margin = 10  # not cut off by the frame's edges (the menu bar at the top is 20 px)
        assert rows.min() > 20 + margin and rows.max() < image.shape[0] - margin
        assert columns.min() > margin and columns.max() < image.shape[1] - margin
    assert html.stat().st_size > 100_000 and "<script" in html.read_text()[:2_000_000]


def test_plots_are_written_and_not_empty(tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        episode = run_episode(DigitSim(), AlipController.for_digit(), Command(0.3, 0.0, 0.2), 2.0)
    paths = save_all(episode, tmp_path)
    assert len(paths) == 5
    for path in paths:
        image = matplotlib.image.imread(path)
        assert path.stat().st_size > 10_000 and image.shape[0] > 300 and image[..., :3].std() > 0.02


def test_replay_animates_the_follow_camera_markers_and_footprints(monkeypatch):
    """The exported replay moves what the live view moves: the world under the follow camera, the
    CoM's colour, the stance-to-CoM segment's length, and each footprint appearing at its touchdown."""
    sim = DigitSim()
    viewer = MeshcatViewer(sim)
    try:
        controller = AlipController.for_digit()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            run_episode(sim, controller, Command(0.5, 0.0, 0.0), 2.0, on_tick=viewer.on_tick(controller))
        captured = []
        monkeypatch.setattr(meshcat.Visualizer, "set_animation", lambda _vis, animation, **_: captured.append(animation))
        viewer.replay()
    finally:
        viewer.close()
    clips = {path.lower(): clip for path, clip in captured[0].clips.items()}
    world = clips["/meshcat"].tracks["position"]
    assert world.values[-1][0] < world.values[0][0] - 0.5  # the world slides back as the robot walks forward
    footprints = sorted(p for p in clips if p.startswith("/meshcat/footsteps/"))
    assert len(footprints) >= 4
    appear = []
    for path in footprints:
        track = clips[path].tracks["visible"]
        assert track.values == [False, True] and track.frames[0] == 0 < track.frames[1]
        appear.append(track.frames[1])
    assert appear == sorted(appear)  # in the order of the touchdowns
    colours = clips["/meshcat/markers/com"].tracks["material.color"].values
    assert len(colours) > 20 and len({tuple(c) for c in colours}) > 1
    lengths = [v[1] for v in clips["/meshcat/markers/alip"].tracks["scale"].values]
    assert 0.8 < min(lengths) and max(lengths) < 1.2 and max(lengths) - min(lengths) > 0.01


def test_velocity_average_has_no_edge_dip_and_footstep_legend_is_unique(monkeypatch, tmp_path):
    from mbc.viz import plots

    constant = np.full(200, 0.4)
    np.testing.assert_allclose(plots.moving_average(constant, 140), 0.4)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        episode = run_episode(DigitSim(), AlipController.for_digit(), Command(0.3), 2.0)
    figures = []
    monkeypatch.setattr(plots, "_save", lambda fig, path: figures.append(fig) or path)
    plots.foot_placements(episode, tmp_path / "f.png")
    axes = figures[0].axes[0]
    labels = [text.get_text() for text in axes.get_legend().get_texts()]
    assert len(labels) == len(set(labels)) == 5
    figures[0].canvas.draw()
    legend_box = axes.get_legend().get_window_extent()
    assert legend_box.y1 < axes.get_window_extent().y0  # below the axes, not over the data


def test_plots_of_a_policy_episode_without_diagnostics(tmp_path):
    from learn.policy import PolicyController

    policy = PolicyController(Path(__file__).resolve().parents[1] / "policies" / "distilled.pt")
    episode = run_episode(DigitSim(), policy, Command(0.3), 1.0)
    assert [p.name for p in save_all(episode, tmp_path)] == ["velocity_tracking.png"]
