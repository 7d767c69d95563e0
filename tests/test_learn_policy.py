"""Policy networks, checkpoints, and the shipped distilled policy walking as a `Controller`."""

from pathlib import Path

import numpy as np
import pytest
import torch

from learn.action import ACTION_DIM, ActionSpace
from learn.checkpoints import deployable_checkpoint, save_torch
from learn.config import EnvConfig
from learn.observation import ObservationLayout, observation_layout
from learn.policy import ActorCritic, Normalizer, PolicyController, load_checkpoint
from mbc.errors import ConfigError
from mbc.rollout import run_episode
from mbc.sim import DigitSim
from mbc.types import Command, Controller

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = ROOT / "policies" / "distilled.pt"


def test_normalizer_round_trip_and_statistics(rng):
    data = rng.normal(loc=[1.0, -3.0, 0.0], scale=[2.0, 0.5, 0.0], size=(5000, 3))
    normalizer = Normalizer(3)
    normalizer.set_statistics(data)
    x = torch.as_tensor(data, dtype=torch.float32)
    y = normalizer(x)
    np.testing.assert_allclose(y[:, :2].mean(0).numpy(), 0.0, atol=1e-4)
    np.testing.assert_allclose(y[:, :2].std(0).numpy(), 1.0, atol=1e-3)
    assert torch.isfinite(y).all()  # the constant feature stays finite (std floored)
    torch.testing.assert_close(normalizer.inverse(y), x, atol=1e-5, rtol=1e-5)


def test_a_seed_fixes_the_initial_weights_and_leaves_torchs_global_stream_alone():
    torch.manual_seed(123)
    expected_next = torch.rand(3)
    torch.manual_seed(123)
    first, second, other = ActorCritic(10, seed=4), ActorCritic(10, seed=4), ActorCritic(10, seed=5)
    assert torch.equal(torch.rand(3), expected_next)
    weights = [model.state_dict() for model in (first, second, other)]
    assert all(torch.equal(weights[0][name], weights[1][name]) for name in weights[0])
    assert not torch.equal(weights[0]["actor.0.weight"], weights[2]["actor.0.weight"])  # another seed, other weights


def test_checkpoint_round_trip_with_weights_only(tmp_path, rng):
    config = EnvConfig()
    model = ActorCritic(ObservationLayout(config.history_length).size)
    model.normalizer.set_statistics(rng.normal(size=(100, model.observation_size)))
    path = tmp_path / "policy.pt"
    save_torch(path, deployable_checkpoint(model, config, ActionSpace()))
    loaded = ActorCritic.from_checkpoint(load_checkpoint(path))
    obs = torch.as_tensor(rng.normal(size=(4, model.observation_size)), dtype=torch.float32)
    torch.testing.assert_close(loaded.action_mean(obs), model.action_mean(obs))
    torch.testing.assert_close(loaded.value(obs), model.value(obs))
    assert loaded.action_mean(obs).shape == (4, ACTION_DIM)


def test_files_that_are_not_policies_give_clear_errors(tmp_path):
    with pytest.raises(ConfigError, match="no policy checkpoint"):
        PolicyController(tmp_path / "missing.pt")
    text = tmp_path / "notes.pt"
    text.write_text("not a checkpoint")
    with pytest.raises(ConfigError, match="not a policy checkpoint"):
        PolicyController(text)
    other = tmp_path / "other.pt"
    torch.save({"weights": torch.zeros(3)}, other)
    with pytest.raises(ConfigError, match="not a policy checkpoint of this project"):
        PolicyController(other)


def test_shipped_policy_walks_as_a_controller():
    controller = PolicyController(SHIPPED)
    assert isinstance(controller, Controller)
    episode = run_episode(DigitSim(seed=1), controller, Command(0.4, 0.0, 0.0), duration_s=6.0)
    assert not episode.fell
    assert episode.base_pos[-1][0] > 1.2  # 0.4 m/s after a start from standing
    mean = episode.mean_velocity(since_s=3.0)
    assert abs(mean[0] - 0.4) < 0.1 and abs(mean[1]) < 0.1


def test_a_checkpoint_trained_with_other_gains_is_refused_by_simulators_and_fine_tuning(tmp_path):
    from learn.finetune import FinetuneConfig, FinetuneRunner
    from robots.digit import constants as digit

    model = ActorCritic(ObservationLayout(EnvConfig().history_length).size)
    path = tmp_path / "stiff.pt"
    save_torch(path, deployable_checkpoint(model, EnvConfig(), ActionSpace(kp=10 * digit.KP, kd=digit.KD)))
    with pytest.raises(ConfigError, match="PD gains other than the simulator's"):
        run_episode(DigitSim(), PolicyController(path), Command(vx=0.3), 0.1)
    with pytest.raises(ConfigError, match="trained with joint gains"):
        FinetuneRunner(FinetuneConfig(init_policy=str(path), run_dir=str(tmp_path / "run")))


def test_a_policy_runs_the_gait_clock_it_was_trained_on_and_fine_tuning_keeps_it(tmp_path):
    from learn.finetune import FinetuneConfig, FinetuneRunner

    model = ActorCritic(ObservationLayout(EnvConfig().history_length).size)
    timed, contact = tmp_path / "timed.pt", tmp_path / "contact.pt"
    save_torch(timed, deployable_checkpoint(model, EnvConfig(gait_clock="time"), ActionSpace()))
    save_torch(contact, deployable_checkpoint(model, EnvConfig(), ActionSpace()))
    assert PolicyController(timed).builder.clock.config.early_touchdown_phase == 1.0
    assert PolicyController(contact).builder.clock.config.early_touchdown_phase == 0.6
    assert PolicyController(SHIPPED).gait_clock == "contact"  # written before the key existed
    with pytest.raises(ConfigError, match="observes the 'time' gait clock"):
        FinetuneRunner(FinetuneConfig(init_policy=str(timed), run_dir=str(tmp_path / "run")))


def test_a_policy_observes_its_heading_error_only_if_trained_so_and_fine_tuning_checks_it(tmp_path):
    from learn.finetune import FinetuneConfig, FinetuneRunner

    holding = EnvConfig(observe_heading_error=True, expert_heading_correction_per_step_rad=0.1)
    model = ActorCritic(observation_layout(holding).size)
    path = tmp_path / "holding.pt"
    save_torch(path, deployable_checkpoint(model, holding, ActionSpace()))
    controller = PolicyController(path)
    assert controller.builder.layout.parts[-1] == ("heading_error", 1)
    assert np.all(np.isfinite(controller.act(DigitSim().state(), Command(vx=0.3)).tau_ff))
    assert PolicyController(SHIPPED).builder.layout.size == observation_layout(EnvConfig()).size  # written before the key
    with pytest.raises(ConfigError, match="trained with the heading error"):
        FinetuneRunner(FinetuneConfig(init_policy=str(path), run_dir=str(tmp_path / "run")))


def test_a_policy_follows_the_commands_it_was_trained_on_turning_limit_included(tmp_path):
    """A distilled policy's limits are its teacher's: (0.8 m/s, 0, 0.8 rad/s) is turned at 0.3 / 0.8 rad/s,
    and the episode summary counts the clipped ticks, as for the MBC."""
    from learn.expert import teacher_command_limits

    model = ActorCritic(ObservationLayout(EnvConfig().history_length).size)
    path = tmp_path / "distilled.pt"
    teacher = teacher_command_limits()
    save_torch(path, deployable_checkpoint(model, EnvConfig(), ActionSpace(), teacher.turn_accel_mps2))
    controller = PolicyController(path)
    assert controller.command_limits.turn_accel_mps2 == teacher.turn_accel_mps2 == pytest.approx(0.3)
    (vx, vy, yaw_rate), clipped = controller.command_limits.clip(Command(vx=0.8, yaw_rate=0.8))
    assert clipped and (vx, vy) == (0.8, 0.0) and yaw_rate == pytest.approx(0.3 / 0.8)
    episode = run_episode(DigitSim(), controller, Command(vx=0.8, yaw_rate=0.8), 0.05)
    assert episode.summary()["clipped_command_ticks"] == len(episode.time)
    untrained = tmp_path / "any.pt"  # trained on every command (fine-tuned): no turning limit
    save_torch(untrained, deployable_checkpoint(model, EnvConfig(), ActionSpace()))
    assert not PolicyController(untrained).command_limits.clip(Command(vx=0.8, yaw_rate=0.8))[1]
