"""`run_episode`, `Episode.summary` and the walk example: bad input, clipped commands, per-axis tracking."""

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mbc.errors import ConfigError
from mbc.rollout import Episode, Push, run_episode
from mbc.sim import DigitSim
from mbc.types import Command, CommandLimits, JointCommand, RobotState

ROOT = Path(__file__).resolve().parents[1]


class Hold:
    """Holds the standing pose; follows commands within a small range (for the clipping records)."""

    dt = 0.005
    command_limits = CommandLimits((-0.1, 0.1), (-0.1, 0.1), (-0.1, 0.1))

    def reset(self, state: RobotState) -> None:
        self.q = state.q.copy()

    def act(self, state: RobotState, command: Command) -> JointCommand:
        return JointCommand.hold(self.q)


@pytest.mark.parametrize("duration", [math.nan, math.inf, 0.001, -1.0, "2"])
def test_durations_that_run_no_tick_are_refused(duration):
    with pytest.raises(ConfigError, match="at least one control period"):
        run_episode(DigitSim(), Hold(), Command(), duration)


@pytest.mark.parametrize("commands, hint", [((0.3, 0.0, 0.0), "plain tuple"), ([], "non-empty list"),
                                            ([(0.0, (0.3, 0, 0))], "non-empty list")])
def test_schedules_that_are_not_commands_are_refused(commands, hint):
    with pytest.raises(ConfigError, match=hint):
        run_episode(DigitSim(), Hold(), commands, 0.1)


def test_a_command_function_returning_something_else_is_refused():
    with pytest.raises(ConfigError, match="not a Command"):
        run_episode(DigitSim(), Hold(), lambda t: (0.3, 0.0, 0.0), 0.1)


@pytest.mark.parametrize("value", ["0.3", None, True, math.nan])
def test_command_fields_must_be_finite_real_numbers(value):
    with pytest.raises(ConfigError, match="Command.vx"):
        Command(vx=value)


def test_pushes_need_a_start_time_and_a_duration():
    with pytest.raises(ConfigError, match="time_s"):
        Push(-3.0, (0.0, 100.0, 0.0))
    with pytest.raises(ConfigError, match="duration_s"):
        Push(1.0, (0.0, 100.0, 0.0), 0.0)


def test_controller_and_simulator_periods_must_agree():
    controller = Hold()
    controller.dt = 0.01
    with pytest.raises(ConfigError, match="every 0.01 s"):
        run_episode(DigitSim(), controller, Command(), 0.1)


def test_the_command_followed_is_recorded_and_clipping_counted():
    episode = run_episode(DigitSim(), Hold(), [(0.0, Command(0.05)), (0.05, Command(1.0, -1.0, 0.0))], 0.1)
    used = episode.arrays("command_used")
    np.testing.assert_allclose(used[0], [0.05, 0.0, 0.0])
    np.testing.assert_allclose(used[-1], [0.1, -0.1, 0.0])
    assert episode.summary(since_s=0.0)["clipped_command_ticks"] == 10


def _synthetic_episode(velocity_xy, yaw_rate, sway_amplitude, duration_s=6.0, dt=0.005) -> Episode:
    """A base moving at a known heading-frame velocity and yaw rate, with a lateral sway of one gait cycle."""
    episode = Episode()
    yaw, position = 0.0, np.zeros(3)
    for k in range(int(round(duration_s / dt))):
        t = k * dt
        sway = sway_amplitude * math.sin(2 * math.pi * t / 0.7)
        heading_velocity = np.array([velocity_xy[0], velocity_xy[1] + sway, 0.0])
        rotation = np.array([[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0], [0, 0, 1]])
        world_velocity = rotation @ heading_velocity
        episode.time.append(t)
        episode.base_pos.append(position.copy())
        episode.base_quat.append(np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]))
        episode.base_linvel.append(world_velocity)
        episode.q.append(np.zeros(12))
        episode.command.append(np.array([*velocity_xy, yaw_rate]))
        episode.command_used.append(np.array([*velocity_xy, yaw_rate]))
        episode.tick_time_s.append(1e-4)
        position += world_velocity * dt
        yaw += yaw_rate * dt
    return episode


def test_tracking_error_is_zero_for_a_trajectory_at_the_command_despite_sway():
    summary = _synthetic_episode((0.4, 0.1), 0.3, sway_amplitude=0.3).summary()
    assert summary["tracking_error_vx_mps"] < 1e-9
    assert summary["tracking_error_vy_mps"] < 1e-3  # the sway averages out over each gait cycle
    assert summary["tracking_error_yaw_rate_radps"] < 1e-9


def test_tracking_error_per_axis_of_a_known_offset():
    episode = _synthetic_episode((0.4, 0.0), 0.0, sway_amplitude=0.0)
    episode.command_used = [c + np.array([0.1, -0.05, 0.2]) for c in episode.command_used]
    summary = episode.summary()
    assert summary["tracking_error_vx_mps"] == pytest.approx(0.1)
    assert summary["tracking_error_vy_mps"] == pytest.approx(0.05)
    assert summary["tracking_error_yaw_rate_radps"] == pytest.approx(0.2)


def test_summary_of_a_short_episode_says_why_it_cannot_judge():
    episode = _synthetic_episode((0.4, 0.0), 0.0, 0.0, duration_s=1.0)
    assert math.isfinite(episode.summary()["tracking_error_vx_mps"])  # default: half of a short episode
    with pytest.raises(ConfigError, match="lasted 1.000 s"):
        episode.summary(since_s=2.0)
    with pytest.raises(ConfigError, match="no ticks"):
        Episode().summary()


def _walk(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(ROOT / "examples" / "walk_mbc.py"), *args], capture_output=True, text=True,
                          timeout=300, cwd=ROOT)


@pytest.mark.parametrize("args, message", [
    (("--angle-deg", "20"), "--angle-deg applies to --terrain slope"),
    (("--duration", "nan"), "at least one control period"),
    (("--push-force", "0", "100", "0", "--push-time", "-3"), "push time_s"),
    (("--terrain", "stairs", "--step-height", "1"), "step_height must be in"),
])
def test_walk_example_refuses_bad_input_with_a_message_and_status_2(args, message):
    result = _walk(*args)
    assert result.returncode == 2
    assert message in result.stderr and "Traceback" not in result.stderr


def test_walk_example_reports_clipping_and_a_fall_and_writes_valid_json(tmp_path):
    out = tmp_path / "summary.json"
    result = _walk("--vx", "1e9", "--duration", "0.3", "--out", str(out))
    assert result.returncode == 0, result.stderr
    assert "beyond the controller's range" in result.stdout and "following (1, 0, 0)" in result.stdout
    summary = json.loads(out.read_text())  # strict JSON: NaN written as null
    assert summary["command_followed"] == [1.0, 0.0, 0.0] and summary["fall_time_s"] is None
    fell = _walk("--vx", "0.2", "--duration", "3", "--push-force", "0", "900", "0", "--push-time", "0.5")
    assert fell.returncode == 1 and "fell: True" in fell.stdout


def test_pd_gains_of_controller_and_simulator_must_agree():
    from mbc.controller import AlipController
    from mbc.sim import SimConfig
    from robots.digit import constants as digit

    stiffer = DigitSim(config=SimConfig(kp=2 * digit.KP))
    with pytest.raises(ConfigError, match="PD gains other than the simulator's"):
        run_episode(stiffer, AlipController.for_digit(), Command(), 0.1)
    run_episode(stiffer, AlipController.for_digit(kp=2 * digit.KP), Command(), 0.1)  # told: fine
    run_episode(stiffer, AlipController.for_digit(output="torque"), Command(), 0.1)  # no PD conversion


def test_turn_acceleration_limit_reduces_the_yaw_rate_and_keeps_the_speed():
    limits = CommandLimits(turn_accel_mps2=0.3)
    (vx, vy, yaw_rate), clipped = limits.clip(Command(0.4, -0.3, -0.8))  # |v| = 0.5: 0.4 m/s^2 asked
    assert (vx, vy) == (0.4, -0.3) and yaw_rate == pytest.approx(-0.6) and clipped
    assert limits.clip(Command(0.2, 0.0, 0.5)) == ((0.2, 0.0, 0.5), False)  # 0.1 m/s^2: as given
    assert limits.clip(Command(0.0, 0.0, 0.8)) == ((0.0, 0.0, 0.8), False)  # turning in place
    assert "0.3 m/s^2" in limits.describe()
    with pytest.raises(ConfigError, match="turn_accel_mps2"):
        CommandLimits(turn_accel_mps2=0.0)
