"""ALIP closed form, step-to-step map and foot placement identities."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from mbc.alip import AlipModel
from mbc.errors import ConfigError


def test_closed_form_equals_numerical_integration(rng):
    for _ in range(25):
        mass, height = rng.uniform(10, 120), rng.uniform(0.5, 1.3)
        x0, L0, u, t = rng.uniform(-0.3, 0.3), rng.uniform(-40, 40), rng.uniform(-30, 30), rng.uniform(0.01, 0.8)
        model = AlipModel(mass, height)

        def ode(_, s, model=model, u=u):
            return [s[1] / model.mz, model.mass * model.gravity * s[0] + u]

        numeric = solve_ivp(ode, (0, t), [x0, L0], method="DOP853", rtol=1e-12, atol=1e-12).y[:, -1]
        x_t, L_t = model.propagate(x0, L0, t, u_ankle=u)
        assert x_t == pytest.approx(numeric[0], abs=1e-8)
        assert L_t / model.mz == pytest.approx(numeric[1] / model.mz, abs=1e-8)  # compared in m/s


def test_propagate_is_a_flow_and_broadcasts(rng):
    model = AlipModel(47.9, 0.95)
    x, L = rng.uniform(-0.2, 0.2, 50), rng.uniform(-20, 20, 50)
    t1, t2 = rng.uniform(0, 0.4, 50), rng.uniform(0, 0.4, 50)
    composed = model.propagate(*model.propagate(x, L, t1), t2)
    np.testing.assert_allclose(composed, model.propagate(x, L, t1 + t2), rtol=1e-12, atol=1e-12)
    grid = model.propagate(x[:, None], L[:, None], np.linspace(0, 0.4, 7)[None, :])
    assert grid[0].shape == (50, 7)
    np.testing.assert_allclose(model.propagate(x, L, 0.0), (x, L))


def test_orbital_energy_is_conserved(rng):
    model = AlipModel(47.9, 1.01)
    x, L = rng.uniform(-0.2, 0.2, 20), rng.uniform(-20, 20, 20)
    energy = model.orbital_energy(x, L)
    for t in (0.1, 0.3, 0.7):
        np.testing.assert_allclose(model.orbital_energy(*model.propagate(x, L, t)), energy, rtol=1e-10, atol=1e-12)


def test_step_to_step_matrices_match_propagation(rng):
    model = AlipModel(47.9, 0.95)
    A, B = model.step_to_step(0.35)
    s, step = np.array([0.1, 12.0]), 0.3
    np.testing.assert_allclose(A @ s + B * step, model.propagate(s[0] - step, s[1], 0.35), rtol=1e-12)
    for t in (0.0, 0.17):  # the transition matrix over any t >= 0, zero included (a late step: no time left)
        np.testing.assert_allclose(model.transition_matrix(t) @ s, model.propagate(s[0], s[1], t), rtol=1e-12)


def test_scalar_one_step_placement_is_flow_then_foot_placement(rng):
    """Predict (x, L) to touchdown, place the foot, and the next step ends with the desired momentum."""
    model, T = AlipModel(47.9, 0.95), 0.35
    for x, L, time_left, L_des in zip(rng.uniform(-0.2, 0.2, 5), rng.uniform(-20, 20, 5), [0.0, 0.05, 0.1, 0.2, 0.35],
                                      rng.uniform(-20, 20, 5)):
        step = model.one_step_placement(x, L, time_left, L_des, T)
        x_end, L_end = model.propagate(x, L, time_left)
        assert step == pytest.approx(x_end + model.foot_placement(L_end, L_des / model.mz, T), rel=1e-12, abs=1e-12)
        _, L_next = model.propagate(x_end - step, L_end, T)  # the CoM relative to the new contact
        assert L_next == pytest.approx(L_des, abs=1e-9)


def test_time_left_for_step_is_the_latest_time_the_one_step_law_gives_that_step(rng):
    """A diverging lateral state needs ever wider steps: the root is where the law's step equals the
    bound, and every later time in range needs a wider one."""
    model, T = AlipModel(47.9, 0.95), 0.35
    for x, L, L_des in zip(rng.uniform(-0.15, 0.0, 20), rng.uniform(-40, -5, 20), rng.uniform(-15, 15, 20)):
        wide = model.one_step_placement(x, L, 0.3, L_des, T)
        bound = 0.5 * (model.one_step_placement(x, L, 0.05, L_des, T) + wide)  # met in between
        t = model.time_left_for_step(x, L, L_des, T, bound, 0.05, 0.3)
        assert t is not None and 0.05 <= t <= 0.3
        assert model.one_step_placement(x, L, t, L_des, T) == pytest.approx(bound, abs=1e-9)
        later = np.linspace(t, 0.3, 20)[1:]
        assert all(model.one_step_placement(x, L, s, L_des, T) < bound for s in later)
    # a step the law cannot give in the range
    assert model.time_left_for_step(-0.1, -30.0, 0.0, T, 5.0, 0.05, 0.3) is None


@pytest.mark.parametrize("v_des", [-0.3, 0.0, 0.5, 1.2])
def test_one_step_foot_placement_reaches_desired_momentum(v_des, rng):
    model = AlipModel(47.9, 0.95)
    T = 0.35
    for L_end in rng.uniform(-30, 30, 5):
        p = model.foot_placement(L_end, v_des, T)
        _, L_next = model.propagate(-p, L_end, T)
        assert L_next == pytest.approx(model.mz * v_des, abs=1e-10)


def test_mean_velocity_of_periodic_gait(rng):
    """Stepping with v_end = end_velocity_for_mean(v) gives a periodic gait of mean velocity v."""
    model, T, v = AlipModel(47.9, 0.95), 0.35, 0.4
    v_end = model.end_velocity_for_mean(v, T)
    L = model.mz * v_end
    p = model.foot_placement(L, v_end, T)
    x_end, L_next = model.propagate(-p, L, T)
    assert L_next == pytest.approx(L)
    assert (x_end + p) / T == pytest.approx(v)  # distance the CoM travels in one step over T


def test_lateral_two_step_gait_is_a_fixed_point():
    model, T, width = AlipModel(47.9, 0.95), 0.35, 0.3
    L_left_end = model.lateral_end_momentum(+1, width, T)  # end of left stance: heading right
    L_right_end = model.lateral_end_momentum(-1, width, T)
    assert L_left_end == pytest.approx(-L_right_end) and L_left_end < 0
    y, L = -width / 2, L_left_end  # CoM right of the left foot by half the width
    feet = []
    for stance in (+1, -1, +1, -1):
        target = model.lateral_end_momentum(-stance, width, T)
        p = model.foot_placement(L, target / model.mz, T)
        feet.append(y + p)  # new foot relative to the old one
        y, L = model.propagate(-p, L, T)
        assert L == pytest.approx(target)
    np.testing.assert_allclose(feet, [-width, width, -width, width])
    assert y == pytest.approx(-width / 2)  # back at the end of a left stance


def test_ankle_torque_shifts_the_equilibrium():
    model = AlipModel(47.9, 0.95)
    u = 20.0
    x_eq = -u / (model.mass * model.gravity)
    np.testing.assert_allclose(model.propagate(x_eq, 0.0, 0.5, u_ankle=u), (x_eq, 0.0), atol=1e-12)


def test_bad_input_raises():
    with pytest.raises(ConfigError, match="mass"):
        AlipModel(0.0, 0.95)
    with pytest.raises(ConfigError, match="com_height"):
        AlipModel(47.0, -1.0)
    model = AlipModel(47.0, 0.95)
    with pytest.raises(ConfigError, match="T must be positive"):
        model.foot_placement(10.0, 0.3, 0.0)
    with pytest.raises(ConfigError, match="finite"):
        model.propagate(np.nan, 0.0, 0.1)
    with pytest.raises(ConfigError, match="t must be >= 0"):
        model.propagate(0.0, 0.0, -0.1)
