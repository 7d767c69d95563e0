"""Gait features of a walk, from its soles and contacts: step length, width and duration, swing apex,
joint trajectories over a normalized gait cycle and left/right symmetry; and the distance between
two gaits (how much of the MBC's gait a policy kept).

A step ends at a touchdown (a foot's contact rising after at least `MIN_SWING_S` in the air); its vector
is the touching-down sole minus the other sole at its own last touchdown, in the heading frame at the
touchdown. A gait cycle runs from one left touchdown to the next.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from mbc.geometry import yaw_rotation

MIN_SWING_S = 0.1
CYCLE_SAMPLES = 50
SCALARS = ("step_length_m", "step_width_m", "step_duration_s", "swing_apex_m")


@dataclass(frozen=True)
class GaitFeatures:
    """Means over the steps of one walk; symmetry indices |L - R| / mean(L, R) (0: symmetric)."""

    steps: int
    step_length_m: float
    step_width_m: float
    step_duration_s: float
    swing_apex_m: float
    """Highest sole above the higher of its liftoff and touchdown heights, per swing [m]."""
    length_symmetry: float
    duration_symmetry: float
    joint_cycle: np.ndarray
    """(CYCLE_SAMPLES, n_joints) mean joint angles over a normalized gait cycle [rad]."""

    def as_dict(self) -> dict:
        return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in asdict(self).items()}


def touchdowns(time: np.ndarray, contact: np.ndarray) -> list[tuple[int, int]]:
    """(tick, foot) of each touchdown after a swing of at least MIN_SWING_S, in time order."""
    events = []
    for foot in range(contact.shape[1]):
        c = np.asarray(contact[:, foot], bool)
        rises = np.flatnonzero(c[1:] & ~c[:-1]) + 1
        falls = np.flatnonzero(~c[1:] & c[:-1]) + 1
        for tick in rises:
            lifted = falls[falls < tick]
            if len(lifted) and time[tick] - time[lifted[-1]] >= MIN_SWING_S:
                events.append((int(tick), foot))
    return sorted(events)


def gait_features(time: np.ndarray, soles: np.ndarray, contact: np.ndarray, q: np.ndarray, yaw: np.ndarray,
                  since_s: float = 2.0) -> GaitFeatures | None:
    """Features of the steps that end after `since_s`; None with fewer than four such steps."""
    time, soles, q = np.asarray(time, float), np.asarray(soles, float), np.asarray(q, float)
    events = touchdowns(time, contact)
    lengths: dict[int, list[float]] = {0: [], 1: []}
    durations: dict[int, list[float]] = {0: [], 1: []}
    widths, apexes = [], []
    for (before, before_foot), (tick, foot) in zip(events[:-1], events[1:]):
        if time[tick] < since_s or before_foot == foot:
            continue
        step = yaw_rotation(yaw[tick]).T @ (soles[tick, foot] - soles[before, 1 - foot])
        lengths[foot].append(float(step[0]))
        widths.append(abs(float(step[1])))
        durations[foot].append(float(time[tick] - time[before]))
        lift = _last_liftoff(contact[:, foot], tick)
        apexes.append(float(soles[lift:tick + 1, foot, 2].max() - max(soles[lift, foot, 2], soles[tick, foot, 2])))
    if len(widths) < 4:
        return None
    left = [tick for tick, foot in events if foot == 0 and time[tick] >= since_s]
    cycles = [_resample(q[a:b + 1]) for a, b in zip(left[:-1], left[1:])]
    return GaitFeatures(
        steps=len(widths), step_length_m=float(np.mean(lengths[0] + lengths[1])), step_width_m=float(np.mean(widths)),
        step_duration_s=float(np.mean(durations[0] + durations[1])), swing_apex_m=float(np.mean(apexes)),
        length_symmetry=_symmetry(lengths), duration_symmetry=_symmetry(durations),
        joint_cycle=np.mean(cycles, axis=0) if cycles else np.full((CYCLE_SAMPLES, q.shape[1]), np.nan))


def _last_liftoff(contact: np.ndarray, tick: int) -> int:
    c = np.asarray(contact[:tick], bool)
    stance = np.flatnonzero(c)
    return int(stance[-1] + 1) if len(stance) else 0


def _resample(q: np.ndarray) -> np.ndarray:
    """(CYCLE_SAMPLES, n) joint angles at evenly spaced phases of one cycle."""
    phase = np.linspace(0.0, 1.0, len(q))
    target = np.linspace(0.0, 1.0, CYCLE_SAMPLES)
    return np.stack([np.interp(target, phase, q[:, j]) for j in range(q.shape[1])], axis=1)


def _symmetry(per_foot: dict[int, list[float]]) -> float:
    left, right = np.mean(per_foot[0]) if per_foot[0] else np.nan, np.mean(per_foot[1]) if per_foot[1] else np.nan
    return float(abs(left - right) / (0.5 * abs(left + right))) if np.isfinite(left + right) and left + right else np.nan


def gait_distance(features: GaitFeatures, reference: GaitFeatures) -> dict[str, float]:
    """Relative difference of each scalar feature (|a - b| / |b|) and the RMS difference of the joint cycles
    [rad]: 0 everywhere for the same gait."""
    distance = {name: abs(getattr(features, name) - getattr(reference, name)) / max(abs(getattr(reference, name)), 1e-9)
                for name in SCALARS}
    distance["joint_cycle_rms_rad"] = float(np.sqrt(np.nanmean((features.joint_cycle - reference.joint_cycle) ** 2)))
    return distance
