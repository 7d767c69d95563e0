"""DAgger: loss, label selection, fitting, the expert's labels, dataset growth, resume after SIGKILL."""

import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import torch

from learn.action import ACTION_DIM
from learn.config import DaggerConfig, DistillConfig, EnvConfig, PushSampling, WorkerConfig
from learn.dagger import DaggerFit, dagger_loss, usable_labels
from learn.dagger_runner import DaggerRunner
from learn.env import WalkEnv
from learn.policy import ActorCritic
from learn.storage import LabelledDataset
from learn.vec_env import InProcessVecEnv, Rollout, RolloutRequest
from mbc.controller import AlipController
from mbc.errors import ConfigError
from mbc.types import CONTROL_PERIOD_S, Command

ROOT = Path(__file__).resolve().parents[1]
QUIET = EnvConfig(terrains=("flat",), pushes=PushSampling(probability=0.0))


def test_dagger_loss_is_the_mean_squared_euclidean_action_error():
    predicted, expert = torch.tensor([[1.0, 2.0], [0.0, 0.0]]), torch.tensor([[0.0, 0.0], [3.0, 4.0]])
    assert float(dagger_loss(predicted, expert)) == pytest.approx((5.0 + 25.0) / 2)


def _rollout(label_valid: np.ndarray, terminated: np.ndarray) -> Rollout:
    steps, envs = label_valid.shape
    zeros = np.zeros((steps, envs))
    return Rollout(observations=np.zeros((steps, envs, 3)), expert_actions=np.zeros((steps, envs, 2)),
                   label_valid=label_valid, label_followed=label_valid, expert_acted=zeros.astype(bool),
                   actions=np.zeros((steps, envs, 2)),
                   rewards=zeros, terminated=terminated, truncated=zeros.astype(bool), monitors=np.zeros((steps, envs, 3)),
                   log_probs=zeros, values=zeros, last_values=np.zeros(envs))


def test_usable_labels_drop_fallbacks_and_the_ticks_before_a_termination():
    valid = np.ones((10, 2), bool)
    valid[1, 1] = False  # a fallback tick
    terminated = np.zeros((10, 2), bool)
    terminated[6, 0] = True
    usable = usable_labels(_rollout(valid, terminated), discard_ticks=3)
    assert usable[:, 0].tolist() == [True] * 4 + [False] * 3 + [True] * 3
    assert usable[:, 1].tolist() == [True, False] + [True] * 8


def test_fit_decreases_the_loss_on_a_fixed_dataset_and_touches_only_the_actor(rng):
    torch.manual_seed(0)
    observations = rng.normal(size=(4000, 20)).astype(np.float32) * 3 + 1
    teacher = rng.normal(size=(20, ACTION_DIM)).astype(np.float32) / 10
    actions = np.tanh(observations @ teacher)
    model = ActorCritic(20)
    critic_before = [p.clone() for p in model.critic.parameters()]
    log_std_before = model.log_std.detach().clone()
    fit = DaggerFit(model, 1e-3)
    before = fit.evaluate(observations, actions)
    fit.fit(observations, actions, steps=300, batch_size=256, learning_rate=1e-3, seed=0)
    after = fit.evaluate(observations, actions)
    assert after < 0.2 * before
    assert all(torch.equal(a, b) for a, b in zip(critic_before, model.critic.parameters()))
    assert torch.equal(log_std_before, model.log_std.detach())


def test_labels_are_those_of_a_standalone_alip_controller():
    """The expert is untouched by the learner: the labels of the states a rollout visits (the expert
    acting; 150 ticks: the weight shift and the first steps) equal the actions of a separate
    AlipController fed the same states in the same order."""
    env = WalkEnv(QUIET, 0)
    env.reset(seed=7)
    states, labels = [], []
    for _ in range(150):
        action, valid = env.label()
        assert valid
        states.append(env.state.copy())
        labels.append(action)
        env.step(action)
    replay = WalkEnv(QUIET, 0, with_expert=False)
    replay.reset(seed=7)  # the same command schedule and clock start
    controller = AlipController.for_digit(output="pd")
    controller.reset(states[0], stance=replay.builder.clock.stance, phase=replay.builder.clock.phase)
    for state, label in zip(states, labels):
        action = env.action_space.from_command(controller.act(state, Command(*replay.command)), state)
        np.testing.assert_allclose(label, action, atol=1e-6)
    rollout = InProcessVecEnv(QUIET, 1).collect(RolloutRequest(None, steps=20, seed=7, beta=1.0))
    assert rollout.label_valid.all() and rollout.expert_acted.all()
    np.testing.assert_array_equal(rollout.actions, rollout.expert_actions)  # beta = 1: the labels were executed


class _RecordingVecEnv(InProcessVecEnv):
    def __init__(self, *args):
        super().__init__(*args)
        self.rollouts = []

    def collect(self, request):
        self.rollouts.append(super().collect(request))
        return self.rollouts[-1]


def _tiny(run_dir: Path, iterations: int = 2, resume: bool = False) -> DistillConfig:
    return DistillConfig(run_dir=run_dir, seed=3, resume=resume, env=QUIET,
                         dagger=DaggerConfig(iterations=iterations, steps_per_env=60, gradient_steps=20, batch_size=128,
                                             beta_decay=0.5),
                         workers=WorkerConfig(workers=0, envs_per_worker=2))


def test_dataset_grows_by_exactly_the_usable_labelled_states(tmp_path):
    runner = DaggerRunner(_tiny(tmp_path / "run"))
    vec_env = _RecordingVecEnv(QUIET, 2)
    runner.learn(vec_env)
    discard = int(round(runner.config.dagger.discard_before_fall_s / CONTROL_PERIOD_S))
    expected = [int(usable_labels(r, discard).sum()) for r in vec_env.rollouts]
    shards = LabelledDataset(tmp_path / "run" / "data")
    shards.load(shards.shards_on_disk())
    assert [len(o) for o in shards.observations] == expected
    assert len(runner.dataset) == sum(expected)
    assert shards.visited == {0: 120, 1: 120}
    with pytest.raises(ConfigError, match="--resume"):
        DaggerRunner(_tiny(tmp_path / "run"))


def _distill_command(run_dir: Path, iterations: int, resume: bool) -> list[str]:
    return [sys.executable, str(ROOT / "examples" / "distill.py"), "--run-dir", str(run_dir), "--seed", "3",
            "--dagger.iterations", str(iterations), "--dagger.steps-per-env", "60", "--dagger.gradient-steps", "20",
            "--dagger.batch-size", "128", "--workers.workers", "0", "--workers.envs-per-worker", "2",
            "--env.terrains", "flat", "--env.pushes.probability", "0"] + (["--resume"] if resume else [])


def test_a_run_killed_with_sigkill_resumes_without_losing_a_sample_and_keeps_the_schedule(tmp_path):
    """Kill -9 once the first checkpoint exists, resume: the shards on disk at the kill are kept as they
    were, and the run ends where an unbroken run ends, bit for bit: the same labelled states and the same
    weights (the initial weights come from the run's seed, the rollouts from (seed, iteration), and the
    MBC's ticks are reproducible: mbc.qp_solver_build)."""
    unbroken = tmp_path / "unbroken"
    subprocess.run(_distill_command(unbroken, 3, False), check=True, capture_output=True, timeout=600)
    killed = tmp_path / "killed"
    process = subprocess.Popen(_distill_command(killed, 3, False), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 300
    while not (killed / "training_state.pt").exists() and time.time() < deadline and process.poll() is None:
        time.sleep(0.02)
    process.send_signal(signal.SIGKILL)
    process.wait()
    at_kill = {p.name: p.read_bytes() for p in (killed / "data").glob("shard_*.npz")}
    assert "shard_00000.npz" in at_kill and "shard_00002.npz" not in at_kill, "the kill came too late"
    result = subprocess.run(_distill_command(killed, 3, True), check=True, capture_output=True, text=True, timeout=600)
    assert "it 3/3" in result.stdout and "it 1/3" not in result.stdout  # the checkpointed iteration is not run again
    for name, data in at_kill.items():
        assert (killed / "data" / name).read_bytes() == data
    for name in ("shard_00000.npz", "shard_00001.npz", "shard_00002.npz"):
        with np.load(unbroken / "data" / name) as a, np.load(killed / "data" / name) as b:
            assert int(a["visited"]) == int(b["visited"]) == 120
            assert all(np.array_equal(a[key], b[key]) for key in a.files), name
    first = torch.load(unbroken / "policy.pt", weights_only=True)
    second = torch.load(killed / "policy.pt", weights_only=True)
    assert first["iteration"] == second["iteration"] == 2
    assert all(torch.equal(a, b) for a, b in zip(first["state_dict"].values(), second["state_dict"].values()))
    assert first["samples"] == second["samples"] == 3 * 120
