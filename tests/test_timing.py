"""Gait clock: phase, touchdown switching, early and late touchdown."""

import numpy as np
import pytest

from mbc.errors import ConfigError
from mbc.timing import LEFT, RIGHT, GaitClock, TimingConfig

NO, LEFT_ONLY, RIGHT_ONLY, BOTH = (np.array(f) for f in ([0, 0], [1, 0], [0, 1], [1, 1]))


def clock(**kwargs) -> GaitClock:
    gait = GaitClock(TimingConfig(step_duration_s=0.4, early_touchdown_phase=0.5, late_touchdown_phase=1.5, **kwargs))
    gait.reset(0.0, LEFT)
    return gait


def test_phase_runs_with_time():
    gait = clock()
    gait.update(0.1, LEFT_ONLY)
    assert gait.phase == pytest.approx(0.25) and gait.time_to_touchdown_s == pytest.approx(0.3)


def test_swing_contact_before_early_phase_is_ignored_after_it_switches():
    gait = clock()
    assert not gait.update(0.15, BOTH)  # phase 0.375: a scuff, not a touchdown
    assert gait.stance == LEFT
    assert gait.update(0.25, BOTH)  # phase 0.625: early touchdown ends the step here
    assert gait.stance == RIGHT and gait.phase == 0.0 and gait.touchdowns == 1


def test_late_touchdown_waits_for_contact_then_forces_a_switch():
    gait = clock()
    assert not gait.update(0.45, LEFT_ONLY)  # past the nominal end, swing foot still in the air
    assert gait.phase > 1 and gait.time_to_touchdown_s == 0.0
    assert gait.update(0.5, BOTH) and gait.stance == RIGHT  # late touchdown
    assert not gait.update(0.5 + 0.59, RIGHT_ONLY)
    assert gait.update(0.5 + 0.61, RIGHT_ONLY) and gait.stance == LEFT  # forced at phase 1.5


def test_retime_keeps_the_phase_and_plans_the_touchdown():
    gait = clock()
    gait.update(0.1, LEFT_ONLY)  # phase 0.25, 0.3 s left
    gait.retime(0.2)
    assert gait.phase == pytest.approx(0.25) and gait.time_to_touchdown_s == pytest.approx(0.2)
    gait.update(0.2, LEFT_ONLY)  # half of the time left: half of the phase left
    assert gait.phase == pytest.approx(0.625) and gait.time_in_step_s == pytest.approx(0.2)
    assert gait.update(0.25, BOTH) and gait.step_duration_s == 0.4  # the next step is at the nominal pace


def test_retime_caps_the_pace_and_leaves_a_late_step():
    gait = clock(min_step_duration_s=0.3)
    gait.update(0.2, LEFT_ONLY)  # phase 0.5
    gait.retime(0.05)  # faster than a 0.3 s step: capped at (1 - 0.5) 0.3 s
    assert gait.time_to_touchdown_s == pytest.approx(0.15)
    gait.update(0.4, LEFT_ONLY)  # late
    gait.retime(0.05)
    assert gait.time_to_touchdown_s == 0.0 and gait.phase > 1
    with pytest.raises(ConfigError, match="positive"):
        gait.retime(0.0)


def test_reset_mid_gait_and_observation():
    gait = GaitClock()
    gait.reset(3.0, RIGHT, phase=0.5)
    assert gait.phase == pytest.approx(0.5)
    obs = gait.observation()
    assert obs.shape == (4,) and obs[3] == 1.0
    # the two-step cycle is continuous across a touchdown: end of right stance == start of left
    gait.reset(0.0, RIGHT, phase=1.0)
    end_of_right = gait.observation()[:2]
    gait.reset(0.0, LEFT, phase=0.0)
    np.testing.assert_allclose(gait.observation()[:2], end_of_right, atol=1e-12)


def test_bad_config():
    with pytest.raises(ConfigError, match="step_duration_s"):
        TimingConfig(step_duration_s=0.0)
    with pytest.raises(ConfigError, match="min_step_duration_s"):
        TimingConfig(min_step_duration_s=0.5)
    with pytest.raises(ConfigError, match="early_touchdown_phase"):
        TimingConfig(early_touchdown_phase=1.2)
    with pytest.raises(ConfigError, match="stance"):
        GaitClock().reset(0.0, 2)
