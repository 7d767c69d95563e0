"""The stride-window yaw rate: sway cancels over a stride, drift and commands pass, wrapping is unwrapped."""

import math

import numpy as np
import pytest

from learn.config import EnvConfig, PushSampling
from learn.env import WalkEnv
from learn.rewards import ang_vel_tracking
from learn.yaw_window import WindowedYawRate
from mbc.errors import ConfigError
from mbc.geometry import wrap_angle, yaw_of_quaternion

DT_S, STRIDE_S = 0.005, 0.7


def test_a_stride_window_cancels_the_sway_and_keeps_the_drift():
    window = WindowedYawRate(STRIDE_S, DT_S)
    drift_radps, sway_rad = -0.11, 0.05
    window.reset(0.0)
    for k in range(1, 1000):
        t = k * DT_S
        rate, command = window.update(drift_radps * t + sway_rad * math.sin(2 * math.pi * t / STRIDE_S), 0.2)
    assert rate == pytest.approx(drift_radps, abs=1e-9)
    assert command == pytest.approx(0.2)


def test_the_window_unwraps_across_pi_and_holds_a_command_step_for_its_length():
    window = WindowedYawRate(STRIDE_S, DT_S)
    window.reset(math.pi - 0.01)
    rates, commands = [], []
    for k in range(1, 400):
        rate, command = window.update(wrap_angle(math.pi - 0.01 + 0.5 * k * DT_S), 0.0 if k <= 200 else 1.0)
        rates.append(rate)
        commands.append(command)
    assert np.allclose(rates, 0.5)
    ticks = round(STRIDE_S / DT_S)
    assert commands[200 + ticks // 2 - 1] == pytest.approx(0.5, abs=1e-9)  # half the window since the step
    assert commands[-1] == pytest.approx(1.0)


def test_the_env_rewards_the_windowed_yaw_rate_and_rejects_a_negative_window():
    config = EnvConfig(terrains=("flat",), pushes=PushSampling(probability=0.0), yaw_rate_window_s=STRIDE_S,
                       ang_vel_tracking_sigma=0.02)
    env = WalkEnv(config)
    env.reset(seed=0)
    env.command = np.array([0.3, 0.0, 0.4])
    shadow = WindowedYawRate(STRIDE_S, env.sim.dt)
    shadow.reset(yaw_of_quaternion(env.state.base_quat))
    for _ in range(50):
        step = env.step(env.label()[0])
        rate, command = shadow.update(yaw_of_quaternion(env.state.base_quat), 0.4)
        assert step.reward_terms["ang_vel_tracking"] == pytest.approx(ang_vel_tracking(rate, command, 0.02))
    with pytest.raises(ConfigError, match="yaw_rate_window_s"):
        EnvConfig(yaw_rate_window_s=-0.1)
    with pytest.raises(ConfigError, match="must be positive"):
        WindowedYawRate(0.0, DT_S)
