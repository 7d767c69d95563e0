"""Plots of a recorded episode (matplotlib, saved as PNG): what is better looked at than read."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from mbc.assumptions import mar_weight
from mbc.rollout import TRACKING_WINDOW_S, Episode
from robots.digit.constants import TOTAL_MASS_KG


def _ticks(episode: Episode) -> list[tuple[float, object]]:
    """(time, diagnostics) of the ticks where the controller ran normally."""
    return [(t, d) for t, d in zip(episode.time, episode.diagnostics)
            if d is not None and not d.fallback and d.alip is not None]


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def phase_portrait(episode: Episode, path: Path) -> Path:
    """ALIP state (x, L / (m z)) about the stance contact, sagittal and lateral, coloured by time."""
    ticks = _ticks(episode)
    times = np.array([t for t, _ in ticks])
    x = np.array([d.alip.x for _, d in ticks])
    L = np.array([d.alip.L for _, d in ticks])
    scale = TOTAL_MASS_KG * np.array([d.alip.com_height_above_contact_m for _, d in ticks])[:, None]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for axis, name in enumerate(("sagittal", "lateral")):
        points = axes[axis].scatter(x[:, axis], L[:, axis] / scale[:, 0], c=times, s=3, cmap="viridis")
        axes[axis].set(xlabel=f"{name} CoM from contact x [m]", ylabel="L / (m z) [m/s]", title=f"ALIP phase portrait, {name}")
    fig.colorbar(points, ax=axes[1], label="time [s]")
    return _save(fig, path)


def moving_average(values: np.ndarray, window: int) -> np.ndarray:
    """Centred mean over `window` samples; near the ends, over the samples there are (no zero padding,
    so a constant signal stays constant to the last sample)."""
    kernel = np.ones(window)
    return np.convolve(values, kernel, mode="same") / np.convolve(np.ones(len(values)), kernel, mode="same")


def velocity_tracking(episode: Episode, path: Path) -> Path:
    """Commanded (and followed, where clipped) against actual heading-frame velocity and yaw rate."""
    t = episode.arrays("time")
    command, followed = episode.arrays("command"), episode.arrays("command_used")
    velocity = episode.heading_velocity()
    yaw = episode.yaw()
    window = max(1, int(TRACKING_WINDOW_S / max(np.median(np.diff(t)), 1e-6)))  # one gait cycle
    fig, axes = plt.subplots(3, 1, figsize=(9, 7), sharex=True)
    actual = (velocity[:, 0], velocity[:, 1], np.gradient(yaw, t))
    for k, (label, unit) in enumerate((("vx", "m/s"), ("vy", "m/s"), ("yaw rate", "rad/s"))):
        axes[k].plot(t, actual[k], color="0.75", lw=0.8, label="actual")
        axes[k].plot(t, moving_average(actual[k], window), color="tab:blue", label="actual, gait-cycle mean")
        axes[k].plot(t, followed[:, k], color="tab:red", lw=2, label="command followed")
        if np.any(command[:, k] != followed[:, k]):
            axes[k].plot(t, command[:, k], color="tab:red", lw=1, ls="--", label="command given (clipped)")
        axes[k].set(ylabel=f"{label} [{unit}]")
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set(xlabel="time [s]")
    axes[0].set_title("Velocity tracking")
    return _save(fig, path)


def foot_placements(episode: Episode, path: Path) -> Path:
    """Top view: planned landing points at touchdown against where the stance feet actually were."""
    ticks = _ticks(episode)
    planned, actual, stance = [], [], []
    previous = None
    for _, d in ticks:
        if d.touchdown and previous is not None:
            planned.append(previous.foot_target_world)
            actual.append(d.stance_sole_world)
            stance.append(d.stance)
        previous = d
    base = episode.arrays("base_pos")
    fig, ax = plt.subplots(figsize=(9, 4))
    ax.plot(base[:, 0], base[:, 1], color="0.6", lw=1, label="pelvis")
    if actual:
        planned, actual, stance = np.array(planned), np.array(actual), np.array(stance)
        for side, colour in ((0, "tab:blue"), (1, "tab:orange")):
            keep = stance == side
            name = "left" if side == 0 else "right"
            ax.scatter(actual[keep, 0], actual[keep, 1], marker="s", color=colour, s=30, label=f"{name} foot, actual")
            ax.scatter(planned[keep, 0], planned[keep, 1], marker="x", color=colour, s=30, label=f"{name} foot, planned")
    ax.set(xlabel="x [m]", ylabel="y [m]", title="Foot placements", aspect="equal")
    ax.legend(fontsize=8, ncols=5, loc="upper center", bbox_to_anchor=(0.5, -0.2))  # below the axes, off the data
    return _save(fig, path)


def violation_timeline(episode: Episode, path: Path) -> Path:
    """The ALIP assumption violations over time, and the MAR weight they imply."""
    ticks = _ticks(episode)
    t = np.array([time for time, _ in ticks])
    report = np.array([d.assumptions.as_array() for _, d in ticks])
    names = ticks[0][1].assumptions.NAMES if ticks else ()
    rows = [(0, "z - z_bar [m]"), (1, "z' [m/s]"), (2, "z'' [m/s^2]"), (3, "stance slip [m/s]")]
    fig, axes = plt.subplots(len(rows) + 1, 1, figsize=(9, 8), sharex=True)
    for ax, (column, label) in zip(axes, rows):
        ax.plot(t, report[:, column], lw=0.8)
        ax.set(ylabel=label)
        ax.axhline(0, color="k", lw=0.5)
    axes[-1].plot(t, mar_weight(report[:, names.index("com_vertical_velocity_mps")]), color="tab:green", lw=0.8)
    axes[-1].set(ylabel="MAR weight", xlabel="time [s]")
    axes[0].set_title("Model-assumption violations")
    return _save(fig, path)


def tick_histogram(episode: Episode, path: Path) -> Path:
    """Histogram of the controller's tick time, with its parts."""
    ticks = _ticks(episode)
    fig, ax = plt.subplots(figsize=(7, 4))
    for part in ("alip", "ik", "qp", "total"):
        values = 1e3 * np.array([d.tick_time_s[part] for _, d in ticks])
        ax.hist(values, bins=60, histtype="step", lw=1.5, label=f"{part} (median {np.median(values):.2f} ms)")
    ax.axvline(5.0, color="k", ls="--", lw=0.8, label="control period 5 ms")
    ax.set(xlabel="time per tick [ms]", ylabel="ticks", title="Controller tick time")
    ax.legend(fontsize=8)
    return _save(fig, path)


def save_all(episode: Episode, directory: str | Path) -> list[Path]:
    """Write every plot of `episode` into `directory`; returns the PNG paths. An episode without the
    controller's diagnostics (a learned policy) gets the velocity plot only."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    velocity = velocity_tracking(episode, directory / "velocity_tracking.png")
    if not _ticks(episode):
        return [velocity]
    return [phase_portrait(episode, directory / "phase_portrait.png"), velocity,
            foot_placements(episode, directory / "foot_placements.png"),
            violation_timeline(episode, directory / "violations.png"),
            tick_histogram(episode, directory / "tick_time.png")]
