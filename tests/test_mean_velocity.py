"""The gait-averaged velocity error and its tracking term: the filter's identities, a steady drift seen through the
sway of walking, a ramped command change not counted as error, and the term in the task's reward."""

import dataclasses
import math

import numpy as np
import pytest

from learn.action import ACTION_DIM
from learn.config import EnvConfig, PushSampling
from learn.env import WalkEnv
from learn.mean_velocity import MeanVelocityError
from learn.rewards import lin_vel_tracking
from mbc.errors import ConfigError

DT_S = 0.005


def test_a_constant_error_has_the_two_stage_step_response():
    error, a = MeanVelocityError(0.5), DT_S / 0.5
    for n in range(1, 101):
        x, y = error.update(1.0, -2.0, (0.0, 0.0, 0.0), n * DT_S, DT_S)
    response = 1 - (1 - a) ** 100 - 100 * a * (1 - a) ** 100
    assert (x, y) == pytest.approx((response, -2.0 * response), rel=1e-12)


def _walk(bias_y_mps: float, sway_mps: float = 0.3, seconds: float = 6.0) -> np.ndarray:
    """The filtered error after walking at 0.5 m/s (command 0.5) with a lateral sway at the 0.7 s gait period."""
    error = MeanVelocityError(0.5)
    for k in range(int(seconds / DT_S)):
        t = k * DT_S
        filtered = error.update(0.5, bias_y_mps + sway_mps * math.sin(2 * math.pi * t / 0.7), (0.5, 0.0, 0.0), t, DT_S)
    return np.array(filtered)


def test_a_steady_drift_shows_through_the_sway_and_the_sway_alone_does_not():
    sway_only, drifting = _walk(0.0), _walk(0.07)
    assert np.abs(sway_only).max() < 0.02
    assert drifting[1] == pytest.approx(0.07, abs=0.02)
    assert lin_vel_tracking(sway_only, np.zeros(2), 0.01) > 0.95
    assert lin_vel_tracking(drifting, np.zeros(2), 0.01) < 0.7


def test_a_velocity_that_follows_the_ramped_command_has_no_error():
    error, rate = MeanVelocityError(0.5, command_rates=(0.8, 0.8, 1.6)), 0.8
    error.update(0.0, 0.0, (0.0, 0.0, 0.0), 0.0, DT_S)  # the first command is followed at once
    for k in range(1, 600):  # a step to 1 m/s at t = 0: followed at 0.8 m/s^2, reached at 1.25 s
        t = k * DT_S
        assert error.update(min(rate * t, 1.0), 0.0, (1.0, 0.0, 0.0), t, DT_S) == pytest.approx((0.0, 0.0), abs=1e-9)
    error.reset()
    assert error.stages == [0.0] * 4 and error.ramp.followed is None


def test_the_weighted_term_adds_to_the_reward_and_is_off_by_default():
    """Off, the reward is the paper's and the term is not computed (it costs 5 us a tick)."""
    quiet = EnvConfig(terrains=("flat",), pushes=PushSampling(probability=0.0))
    plain = WalkEnv(quiet, with_expert=False)
    weighted = WalkEnv(dataclasses.replace(quiet, mean_vel_tracking_weight=2.0), with_expert=False)
    plain.reset(3), weighted.reset(3)
    for _ in range(20):
        a, b = plain.step(np.zeros(ACTION_DIM)), weighted.step(np.zeros(ACTION_DIM))
        assert a.reward_terms == {k: v for k, v in b.reward_terms.items() if k != "mean_vel_tracking"}
        assert b.reward - a.reward == pytest.approx(2.0 * b.reward_terms["mean_vel_tracking"], abs=1e-9)
    assert 0.0 < b.reward_terms["mean_vel_tracking"] <= 1.0


@pytest.mark.parametrize("field, value", [("mean_vel_tracking_weight", -0.5), ("mean_vel_tracking_sigma", 0.0),
                                          ("mean_vel_time_constant_s", -1.0)])
def test_the_term_refuses_bad_settings(field, value):
    with pytest.raises(ConfigError, match=field):
        EnvConfig(**{field: value})
