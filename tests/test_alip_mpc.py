"""The ALIP MPC agrees with the one-step law where it should and respects its bounds."""

import numpy as np
import pytest

from mbc.alip import AlipModel
from mbc.alip_mpc import AlipMpc, AlipMpcConfig, StepReach
from mbc.errors import ConfigError
from mbc.timing import TimingConfig

MODEL = AlipModel(47.93, 0.95)
T = 0.35


def desired(stance_sign: int, v=(0.4, 0.0), width=0.3, n=3) -> np.ndarray:
    """L_des after each of n touchdowns, starting from `stance_sign` stance."""
    rows = []
    for k in range(n):
        next_stance = -stance_sign * (-1) ** k
        rows.append([MODEL.mz * MODEL.end_velocity_for_mean(v[0], T),
                     MODEL.lateral_end_momentum(next_stance, width, T, v[1])])
    return np.array(rows)


@pytest.fixture(scope="module")
def mpc():
    return AlipMpc(MODEL, timing=TimingConfig(step_duration_s=T))


@pytest.mark.parametrize("fixed_timing", [True, False])
def test_matches_one_step_law_without_active_bounds(mpc, fixed_timing):
    x_now, L_now, elapsed = np.array([0.02, -0.1]), np.array([MODEL.mz * 0.3, 2.0]), 0.1
    L_des = desired(+1)
    solution = mpc.solve(x_now, L_now, elapsed, +1, L_des, fixed_timing=fixed_timing)
    assert solution.success
    _, L_end = MODEL.propagate(x_now, L_now, T - elapsed)
    expected = MODEL.foot_placement(L_end, L_des[0] / MODEL.mz, T)
    np.testing.assert_allclose(solution.foot_from_com_m, expected, atol=1e-5)
    assert solution.time_left_s == pytest.approx(T - elapsed, abs=1e-4)


@pytest.mark.parametrize("fixed_timing", [True, False])
def test_a_step_near_its_end_is_not_lengthened_to_the_time_floor(mpc, fixed_timing):
    """0.01 s before the nominal touchdown the plan keeps 0.01 s (not `min_time_left_s`): planning
    with a longer time each tick moved the landing forward and walked 18% below the command."""
    x_now, L_now, elapsed = np.array([0.05, -0.1]), np.array([MODEL.mz * 0.35, -10.0]), T - 0.01
    solution = mpc.solve(x_now, L_now, elapsed, +1, desired(+1), fixed_timing=fixed_timing)
    assert solution.success and mpc.config.min_time_left_s > 0.01
    assert solution.time_left_s == pytest.approx(0.01, abs=1e-4)


def test_step_bounds_bind_and_timing_adapts(mpc):
    """A large forward push: the step hits its length bound, and the MPC shortens the step to help."""
    x_now, L_now, elapsed = np.array([0.1, -0.1]), np.array([MODEL.mz * 2.0, 0.0]), 0.05
    L_des = desired(+1)
    fixed = mpc.solve(x_now, L_now, elapsed, +1, L_des, fixed_timing=True)
    free = mpc.solve(x_now, L_now, elapsed, +1, L_des)
    reach = mpc.reach
    for solution in (fixed, free):
        assert solution.success
        assert np.all(np.abs(solution.steps_m[:, 0]) <= reach.max_length_m + 1e-8)
        signs = np.array([-1, 1, -1])
        assert np.all(signs * solution.steps_m[:, 1] >= reach.min_width_m - 1e-8)
        assert np.all(signs * solution.steps_m[:, 1] <= reach.max_width_m + 1e-8)
    assert fixed.steps_m[0, 0] == pytest.approx(reach.max_length_m, abs=1e-6)
    assert free.time_left_s < fixed.time_left_s - 0.02  # touch down earlier to catch the fall

    def tracking_error(solution):
        x, L = MODEL.propagate(x_now, L_now, solution.durations_s[0])
        errors = []
        for k in range(3):
            x, L = MODEL.propagate(x - solution.steps_m[k], L, solution.durations_s[k + 1])
            errors.append(L - L_des[k])
        return np.sum(np.square(errors))

    assert tracking_error(free) < tracking_error(fixed)


def test_lateral_width_bound_binds(mpc):
    x_now, L_now = np.array([0.0, -0.05]), np.array([0.0, 0.0])
    # a large rightward momentum after a right step would need the right foot left of the left one
    L_des = desired(+1)
    L_des[0, 1] = -90.0
    solution = mpc.solve(x_now, L_now, 0.1, +1, L_des, fixed_timing=True)
    assert solution.steps_m[0, 1] == pytest.approx(-mpc.reach.min_width_m, abs=1e-6)


def test_the_controller_gives_the_mpc_its_own_reach_and_timing():
    """One set of step bounds: the controller's (there is no second copy in AlipMpcConfig to ignore)."""
    from mbc.controller import AlipController

    controller = AlipController.for_digit(foot_placement="mpc", max_step_length_m=0.3, min_step_width_m=0.15,
                                          timing=TimingConfig(step_duration_s=0.4, min_step_duration_s=0.3))
    assert controller.mpc.reach == StepReach(0.3, 0.15, controller.config.max_step_width_m)
    assert controller.mpc.timing is controller.config.timing
    x_now, L_now = np.array([0.1, -0.1]), np.array([MODEL.mz * 2.0, 0.0])
    solution = controller.mpc.solve(x_now, L_now, 0.05, +1, desired(+1), fixed_timing=True)
    assert solution.steps_m[0, 0] == pytest.approx(0.3, abs=1e-6)
    assert not {"max_step_length_m", "min_step_width_m", "max_step_width_m", "step_duration_s"} & set(
        AlipMpcConfig.__dataclass_fields__)


def test_bad_input(mpc):
    with pytest.raises(ConfigError, match="stance_sign"):
        mpc.solve([0, 0], [0, 0], 0.1, 0, desired(+1))
    with pytest.raises(ConfigError, match="finite"):
        mpc.solve([np.nan, 0], [0, 0], 0.1, 1, desired(+1))
    with pytest.raises(ConfigError, match="horizon"):
        AlipMpcConfig(horizon_steps=0)
