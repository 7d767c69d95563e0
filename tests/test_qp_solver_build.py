"""The proxsuite build of the passivity QP: portable by default, and a controller's walk reproducible bit for bit."""

import os
import subprocess
import sys

import numpy as np
import pytest

from mbc import AlipController
from mbc.errors import ConfigError
from mbc.qp_solver_build import BUILD_VARIABLE, loaded_build, requested_build
from mbc.rollout import perturbed_stand
from mbc.sim import DigitSim
from mbc.types import Command


def _python(code: str, build: str | None) -> subprocess.CompletedProcess:
    env = {key: value for key, value in os.environ.items() if key != BUILD_VARIABLE}
    if build is not None:
        env[BUILD_VARIABLE] = build
    return subprocess.run([sys.executable, "-W", "always", "-c", code], env=env, capture_output=True, text=True,
                          timeout=120)


def test_the_portable_build_is_the_default_and_simd_is_proxsuites_own_choice():
    assert loaded_build() == "proxsuite_pywrap"  # this process: the variable is unset in the test environment
    code = "import mbc.passivity; from mbc.qp_solver_build import loaded_build; print(loaded_build())"
    assert _python(code, None).stdout.strip() == "proxsuite_pywrap"
    own_choice = _python("import proxsuite; print(proxsuite._submodule.__name__.rsplit('.', 1)[-1])", None)
    assert _python(code, "simd").stdout.strip() == own_choice.stdout.strip()  # AVX-512 or AVX2 where the CPU has them


def test_a_bad_build_is_refused_and_an_earlier_wide_import_is_reported(monkeypatch):
    monkeypatch.setenv(BUILD_VARIABLE, "fast")
    with pytest.raises(ConfigError, match="valid: portable, simd"):
        requested_build()
    earlier = _python("import proxsuite, mbc.passivity; print(proxsuite._submodule.__name__)", None)
    if earlier.stdout.strip() != "proxsuite.proxsuite_pywrap":  # a CPU with AVX2: proxsuite chose a wide build
        assert "not bitwise reproducible" in earlier.stderr


def _walk_actions(ticks: int) -> np.ndarray:
    sim, controller = DigitSim(), AlipController()
    state = perturbed_stand(sim, seed=3)
    controller.reset(state)
    actions = []
    for _ in range(ticks):
        action = controller.act(state, Command(0.5, 0.1, 0.2))
        actions.append(np.r_[action.q_des, action.qd_des, action.tau_ff])
        state = sim.step(action)
    return np.array(actions)


def test_two_walks_from_the_same_state_are_identical_bit_for_bit():
    """With proxsuite's AVX builds the same walk differed from 1e-13 at the first tick to 1e-2 after 300 ticks
    (mbc.qp_solver_build); every part of the tick is now deterministic, so the actions are equal exactly."""
    first, second = _walk_actions(400), _walk_actions(400)
    assert np.array_equal(first, second), np.abs(first - second).max()
