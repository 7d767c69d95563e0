"""examples/observation_sensitivity.py: a linear policy's sensitivities are its weights' norms per observation part
(over the normalizer's scale), and bad settings are refused."""

import importlib.util
import sys
from pathlib import Path

import pytest
import torch

from learn.config import PolicyConfig
from learn.policy import ActorCritic, load_checkpoint
from mbc.errors import ConfigError

ROOT = Path(__file__).resolve().parents[1]


def _script():
    spec = importlib.util.spec_from_file_location("observation_sensitivity", ROOT / "examples" / "observation_sensitivity.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["observation_sensitivity"] = module
    spec.loader.exec_module(module)
    return module


def test_a_linear_policys_sensitivity_is_its_weight_norm_per_part(tmp_path):
    script = _script()
    shipped = load_checkpoint(ROOT / "policies" / "distilled.pt")
    linear = ActorCritic(shipped["observation_size"], PolicyConfig(actor_hidden=(), critic_hidden=()), seed=0)
    linear.normalizer.std.copy_(torch.linspace(0.5, 2.0, shipped["observation_size"]))
    path = tmp_path / "linear.pt"
    torch.save(shipped | linear.checkpoint(), path)
    norms, _ = script.sensitivity(path, (0.3, 0.0, 0.0), duration_s=0.05, settle_s=0.0, every=1)
    weight = linear.actor[0].weight.detach() / linear.normalizer.std
    expected = [float(weight[:, s].norm()) for s in (slice(0, 3), slice(3, 6), slice(12, 24), slice(24, 36))]
    assert norms == pytest.approx(expected, rel=1e-5)


def test_bad_settings_are_refused():
    script = _script()
    for settings in (dict(every=0), dict(duration_s=1.0, settle_s=2.0), dict(settle_s=-1.0)):
        with pytest.raises(ConfigError, match="--every"):
            script.main(script.Args(policies=[ROOT / "policies" / "distilled.pt"], **settings))
