"""The protocols' figures, computed from recorded trajectories (pure functions, tested on trajectories
with known answers)."""

from __future__ import annotations

import numpy as np

from learn.rewards import PAPER_WEIGHTS, ang_vel_tracking, lin_vel_tracking
from mbc.rollout import TRACKING_WINDOW_S, Episode


def sustained_velocity(episode: Episode, hold_s: float = 2.0, tolerance_mps: float = 0.15) -> float:
    """The highest forward speed held for `hold_s` (consecutive gait-cycle windows) within `tolerance_mps`
    of the command followed [m/s]."""
    velocity, command = episode.window_velocity()
    if not len(velocity):
        return 0.0
    window_s = float(episode.time[1] - episode.time[0]) * episode.window_ticks()
    needed = max(int(round(hold_s / window_s)), 1)
    good = np.abs(velocity[:, 0] - command[:, 0]) <= tolerance_mps
    best = 0.0
    for k in range(len(good) - needed + 1):
        if good[k:k + needed].all():
            best = max(best, float(velocity[k:k + needed, 0].min()))
    return best


def largest_oscillation(episode: Episode, since_s: float = 1.0, window_s: float = TRACKING_WINDOW_S) -> tuple[float, float]:
    """The largest peak-to-peak, within one gait cycle (consecutive windows of `window_s` after `since_s`), of the
    heading-frame forward speed [m/s] and of the yaw [deg]: a loop that oscillates grows them window by window.
    The cycle before a fall is left out (the fall's own tumble is not the oscillation that led to it); (0, 0) when
    no whole window remains."""
    t = episode.arrays("time")
    start = int(np.searchsorted(t, since_s))
    ticks = episode.window_ticks(window_s)
    end = len(t) - ticks if episode.fell else len(t)
    speed, yaw = episode.heading_velocity()[:, 0], np.degrees(episode.yaw())
    windows = [slice(k, k + ticks) for k in range(start, end - ticks + 1, ticks)]
    if not windows:
        return 0.0, 0.0
    return (float(max(np.ptp(speed[w]) for w in windows)), float(max(np.ptp(yaw[w]) for w in windows)))


def incline_speed_error_pct(episode: Episode, x_from_m: float, x_to_m: float, commanded_mps: float,
                            min_ticks: int = 100) -> float:
    """|mean forward speed while the pelvis is within [x_from, x_to] - command| in % of the command;
    NaN when fewer than `min_ticks` ticks were spent there (a fall before the incline)."""
    x = episode.arrays("base_pos")[:, 0]
    inside = (x > x_from_m) & (x < x_to_m)
    if inside.sum() < min_ticks:
        return float("nan")
    speed = float(episode.heading_velocity()[inside, 0].mean())
    return 100.0 * abs(speed - commanded_mps) / abs(commanded_mps)


def levels_completed(x_reached_m: float, level_starts_m: np.ndarray) -> int:
    """How many course levels lie behind `x_reached_m`, given where each begins and the last ends
    (`mbc.sim.terrain.Course.level_starts_m`)."""
    return int(np.searchsorted(np.asarray(level_starts_m)[1:], x_reached_m, side="right"))


def tracking_return(episode: Episode, lin_sigma: float, ang_sigma: float) -> float:
    """Undiscounted return of the paper's two tracking rewards, sum_t (1.2 r_lin + 1.1 r_ang) dt: 2.3 per
    second of perfect tracking, less for each error and nothing after a fall."""
    if len(episode.time) < 2:
        return 0.0
    dt = float(episode.time[1] - episode.time[0])
    velocity, command = episode.heading_velocity(), episode.arrays("command")
    yaw_rate = np.gradient(episode.yaw(), dt)
    total = sum(PAPER_WEIGHTS["lin_vel_tracking"] * lin_vel_tracking(v, c[:2], lin_sigma)
                + PAPER_WEIGHTS["ang_vel_tracking"] * ang_vel_tracking(w, c[2], ang_sigma)
                for v, w, c in zip(velocity, yaw_rate, command))
    return float(total * dt)


def mean_ci95(values) -> tuple[float, float]:
    """Mean of the finite values and the half-width of its 95% confidence interval (normal, 1.96 s / sqrt n;
    NaN with fewer than two)."""
    finite = np.asarray(values, float)
    finite = finite[np.isfinite(finite)]
    if not len(finite):
        return float("nan"), float("nan")
    ci = 1.96 * finite.std(ddof=1) / np.sqrt(len(finite)) if len(finite) > 1 else float("nan")
    return float(finite.mean()), float(ci)
