"""The pull toward the expert fitted at the noise-free observations: the environment keeps them, a rollout records
them when asked, the regularizer evaluates mu there, and the option is refused where there is no regularizer."""

import copy
import dataclasses

import numpy as np
import pytest
import torch

from learn.config import EnvConfig, PushSampling, Randomization
from learn.env import WalkEnv
from learn.finetune import FinetuneConfig
from learn.losses import expert_regularizer, mar_weight
from learn.policy import ActorCritic
from learn.ppo import Ppo, PpoConfig, RegularizerConfig, method_regularizer
from learn.vec_env import InProcessVecEnv, Rollout, RolloutRequest
from mbc.errors import ConfigError

NOISY = EnvConfig(terrains=("flat",), pushes=PushSampling(probability=0.0), randomization=Randomization(observation_noise=1.0))


def test_the_noise_free_observation_is_the_observation_less_its_bounded_noise():
    env = WalkEnv(NOISY, with_expert=False)
    env.reset(3)
    for _ in range(3):
        env.step(np.zeros(24))
        noise = env.observation - env.true_observation
        assert np.all(np.abs(noise) <= env._noise_scale + 1e-12)
        assert np.any(noise != 0.0) and np.all(noise[env._noise_scale == 0] == 0.0)  # commands and clock stay exact
    quiet = WalkEnv(dataclasses.replace(NOISY, randomization=Randomization()), with_expert=False)
    quiet.reset(3)
    quiet.step(np.zeros(24))
    np.testing.assert_array_equal(quiet.observation, quiet.true_observation)


def test_a_rollout_records_the_noise_free_observations_only_when_asked():
    vec_env = InProcessVecEnv(NOISY, 2, with_expert=False)
    policy = ActorCritic(vec_env.observation_size).checkpoint()
    plain = vec_env.collect(RolloutRequest(policy, steps=4, seed=0, label_every=0, stochastic=True))
    assert plain.true_observations is None
    asked = vec_env.collect(RolloutRequest(policy, steps=4, seed=0, label_every=0, stochastic=True, true_observations=True))
    assert asked.true_observations.shape == asked.observations.shape
    noise_scale = vec_env.group.envs[0]._noise_scale
    assert np.all(np.abs(asked.observations - asked.true_observations) <= noise_scale + 1e-6)
    assert not np.array_equal(asked.observations, asked.true_observations)
    joined = Rollout.concatenate([asked, asked])
    assert joined.true_observations.shape == (4, 4, vec_env.observation_size)
    assert Rollout.concatenate([plain, plain]).true_observations is None


def _labelled_rollout(rng, T=6, n=2, size=10):
    return Rollout(observations=rng.normal(size=(T, n, size)).astype(np.float32),
                   expert_actions=rng.normal(size=(T, n, 24)).astype(np.float32),
                   label_valid=rng.random((T, n)) < 0.5, label_followed=np.ones((T, n), bool),
                   expert_acted=np.zeros((T, n), bool), actions=rng.normal(size=(T, n, 24)).astype(np.float32),
                   rewards=rng.normal(size=(T, n)).astype(np.float32), terminated=np.zeros((T, n), bool),
                   truncated=np.zeros((T, n), bool), monitors=rng.normal(scale=0.1, size=(T, n, 3)).astype(np.float32),
                   log_probs=np.full((T, n), -20.0, np.float32), values=np.zeros((T, n), np.float32),
                   last_values=np.zeros(n, np.float32))


def _first_regularizer(model: ActorCritic, regularizer: RegularizerConfig, rollout: Rollout) -> float:
    """The regularizer term of one update of one minibatch (computed before the step, on `model` as given)."""
    return Ppo(copy.deepcopy(model), PpoConfig(epochs=1, minibatches=1), regularizer).update(rollout)["regularizer"]


def test_the_regularizer_is_fitted_at_the_noise_free_observations_when_asked(rng):
    """E[w ||a_E - mu(o_true)||^2] over the labelled samples; the same as the paper's when o_true = o."""
    torch.manual_seed(0)
    model, rollout = ActorCritic(10), _labelled_rollout(rng)
    paper, true = method_regularizer("ppf"), dataclasses.replace(method_regularizer("ppf"), true_observations=True)
    rollout.true_observations = rollout.observations.copy()
    assert _first_regularizer(model, true, rollout) == pytest.approx(_first_regularizer(model, paper, rollout), rel=1e-6)
    rollout.true_observations = rollout.observations + rng.normal(size=rollout.observations.shape).astype(np.float32)
    flat = {name: torch.as_tensor(getattr(rollout, name)).reshape(12, -1).squeeze(-1)
            for name in ("true_observations", "expert_actions", "monitors", "label_valid")}
    with torch.no_grad():
        expected = expert_regularizer(model.action_mean(flat["true_observations"]), flat["expert_actions"],
                                      mar_weight(flat["monitors"][:, :1], torch.tensor(true.deltas), true.w0),
                                      flat["label_valid"])
    fitted = _first_regularizer(model, true, rollout)
    assert fitted == pytest.approx(float(expected), rel=1e-5)
    assert fitted != pytest.approx(_first_regularizer(model, paper, rollout), rel=1e-3)


def test_the_option_is_refused_without_a_regularizer_or_without_the_observations(rng):
    with pytest.raises(ConfigError, match="needs a regularizer"):
        RegularizerConfig("none", label_every=0, true_observations=True)
    for method in ("ifm", "purerl"):
        with pytest.raises(ConfigError, match="only ppf and fullreg"):
            FinetuneConfig(method=method, regularize_true_observations=True)
    assert FinetuneConfig(method="fullreg", regularize_true_observations=True).regularizer().true_observations
    true = dataclasses.replace(method_regularizer("ppf"), true_observations=True)
    with pytest.raises(ConfigError, match="RolloutRequest\\(true_observations=True\\)"):
        Ppo(ActorCritic(10), PpoConfig(epochs=1, minibatches=1), true).update(_labelled_rollout(rng))
