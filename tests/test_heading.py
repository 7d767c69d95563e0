"""`mbc.heading.HeadingSetpoint`: psi_ref = psi_0 + integral of the followed yaw rate, within a bound of the heading."""

import math

import pytest

from mbc.geometry import wrap_angle
from mbc.heading import HeadingSetpoint


def test_the_setpoint_integrates_the_rate_followed_since_the_last_update():
    setpoint = HeadingSetpoint(max_error_rad=1.0)
    setpoint.reset(0.1, time_s=2.0)
    assert setpoint.update(0.1, 2.0, yaw_rate_radps=0.4) == pytest.approx(0.1)
    assert setpoint.update(0.2, 2.5, yaw_rate_radps=-0.2) == pytest.approx(0.1 + 0.4 * 0.5)  # a gap of ticks counts
    assert setpoint.update(0.3, 3.5, yaw_rate_radps=0.0) == pytest.approx(0.3 - 0.2 * 1.0)


def test_the_setpoint_stays_within_its_bound_of_the_heading():
    setpoint = HeadingSetpoint(max_error_rad=0.5)
    setpoint.reset(0.0, time_s=0.0)
    setpoint.update(0.0, 0.0, yaw_rate_radps=1.0)
    assert setpoint.update(0.0, 2.0, yaw_rate_radps=1.0) == pytest.approx(0.5)  # a robot that does not turn
    assert setpoint.update(0.1, 2.1, yaw_rate_radps=0.0) == pytest.approx(0.6)  # 0.6 from 0.5 + 0.1: bound moves with it
    assert setpoint.update(-1.0, 2.1, yaw_rate_radps=0.0) == pytest.approx(-0.5)  # pushed round by 1.1 rad


def test_the_setpoint_wraps_across_pi():
    setpoint = HeadingSetpoint(max_error_rad=0.5)
    setpoint.reset(3.1, time_s=0.0)
    setpoint.update(3.1, 0.0, yaw_rate_radps=0.2)
    reference = setpoint.update(-3.1, 0.5, yaw_rate_radps=0.0)  # the robot turned through pi as commanded
    assert wrap_angle(reference - 3.2) == pytest.approx(0.0, abs=1e-12)
    assert abs(reference - -3.1) < 0.5 and not math.isclose(reference, 3.2)
