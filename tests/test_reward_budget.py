"""examples/reward_budget.py: scored against its own command, a walk's tracking column is its weighted tracking term;
a held command never changes; bad settings are refused."""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from learn.config import CommandSampling, EnvConfig
from learn.env import sample_command
from mbc.errors import ConfigError

ROOT = Path(__file__).resolve().parents[1]
DISTILLED = ROOT / "policies" / "distilled.pt"


def _script():
    spec = importlib.util.spec_from_file_location("reward_budget", ROOT / "examples" / "reward_budget.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["reward_budget"] = module
    spec.loader.exec_module(module)
    return module


def test_scored_at_its_own_command_the_tracking_column_is_the_weighted_term():
    script = _script()
    b = script.budget(DISTILLED, 0.4, 0.4, duration_s=1.0, settle_s=0.5)
    assert not b.fell
    assert b.tracking_at_score == pytest.approx(b.weighted_terms["lin_vel_tracking"], rel=1e-9)
    assert b.weighted_terms["torque"] < 0 and b.weighted_terms["base_motion"] <= 0
    other = script.budget(DISTILLED, 0.4, 1.0, duration_s=1.0, settle_s=0.5)
    assert other.tracking_at_score < b.tracking_at_score  # 0.6 m/s further from what it walks


def test_a_held_command_is_every_draw_and_outlasts_an_episode():
    held = CommandSampling.held(0.3, -0.1, 0.2)
    rng = np.random.default_rng(0)
    for _ in range(200):
        np.testing.assert_allclose(sample_command(rng, held), [0.3, -0.1, 0.2])
    assert held.resample_interval_s[0] > 100 * EnvConfig().episode_length_s and not held.widened


def test_bad_settings_are_refused():
    script = _script()
    for settings in (dict(duration_s=1.0, settle_s=2.0), dict(settle_s=-1.0), dict(commands=())):
        with pytest.raises(ConfigError, match="--settle-s"):
            script.main(script.Args(policies=[DISTILLED], **settings))
