"""The noise-free observations the pull toward the expert can be fitted at: the environment keeps them and a rollout
records them when asked (the fit itself: tests/test_learn_ppo.py)."""

import dataclasses

import numpy as np

from learn.config import EnvConfig, PushSampling, Randomization
from learn.env import WalkEnv
from learn.policy import ActorCritic
from learn.vec_env import InProcessVecEnv, Rollout, RolloutRequest

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
