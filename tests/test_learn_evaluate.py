"""Evaluation protocols: metrics on trajectories with known answers, bad input, a short protocol on the
MBC; the main job end to end in miniature, with its ONNX export checked against torch."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import onnxruntime
import pytest
import torch

from learn.evaluate import check_protocols, evaluate, sustained_velocity
from learn.policy import ActorCritic, load_checkpoint
from mbc.errors import ConfigError
from mbc.rollout import Episode

ROOT = Path(__file__).resolve().parents[1]


def _ramp_episode(speed_of, duration_s=10.0, dt=0.005) -> Episode:
    """Forward motion at speed_of(t), command ramping 0.5 + 0.1 t."""
    episode, x = Episode(), 0.0
    for k in range(int(duration_s / dt)):
        t = k * dt
        episode.time.append(t)
        episode.base_pos.append(np.array([x, 0.0, 1.0]))
        episode.base_quat.append(np.array([1.0, 0.0, 0.0, 0.0]))
        episode.base_linvel.append(np.array([speed_of(t), 0.0, 0.0]))
        episode.q.append(np.zeros(12))
        episode.command.append(np.array([0.5 + 0.1 * t, 0.0, 0.0]))
        episode.command_used.append(np.array([0.5 + 0.1 * t, 0.0, 0.0]))
        episode.tick_time_s.append(0.0)
        x += speed_of(t) * dt
    return episode


def test_sustained_velocity_of_known_trajectories():
    tracking = _ramp_episode(lambda t: 0.5 + 0.1 * t)
    # gait-cycle windows of 0.7 s; the last three whole ones (2 s) start at 7.7 s: the slowest averages 0.5 + 0.1 * 8.05
    assert sustained_velocity(tracking) == pytest.approx(1.305, abs=0.005)
    stalls = _ramp_episode(lambda t: min(0.5 + 0.1 * t, 0.9))  # stops at 0.9 while the command goes on to 1.5
    assert sustained_velocity(stalls) == pytest.approx(0.9, abs=0.03)


def test_unknown_protocols_and_non_policies_are_refused_with_the_valid_choices(tmp_path):
    with pytest.raises(ConfigError, match="valid"):
        check_protocols(("flat", "moonwalk"))
    check_protocols(("uphill_18", "uneven_3.5"))
    bogus = tmp_path / "notes.txt"
    bogus.write_text("hello")
    with pytest.raises(ConfigError, match="not a policy checkpoint"):
        evaluate([str(bogus)], ("flat",), seeds=1, workers=1)
    result = subprocess.run([sys.executable, "-m", "learn.evaluate", "--protocols", "skydive"], capture_output=True,
                            text=True, cwd=ROOT, timeout=120)
    assert result.returncode == 2 and "valid" in result.stderr


def test_uphill_protocol_on_the_mbc_produces_its_table():
    results = evaluate(["mbc"], ("uphill_8",), seeds=1, workers=1)
    row = results.rows[0]
    assert row["controller"] == "MBC" and row["successes"] == 1 and row["metric"] < 30.0  # within 30% of 0.5 m/s
    assert "| MBC | uphill_8 | 1/1 |" in results.table()


def test_main_job_in_miniature_fine_tunes_and_exports_onnx_that_agrees_with_torch(tmp_path):
    result = subprocess.run([sys.executable, str(ROOT / "examples" / "distill_and_finetune.py"), "--method", "ifm",
                             "--run-dir", str(tmp_path), "--iterations", "2", "--evaluation-seeds", "0",
                             "--workers.workers", "0", "--workers.envs-per-worker", "2"],
                            capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert result.returncode == 0, result.stderr[-2000:]
    model = ActorCritic.from_checkpoint(load_checkpoint(tmp_path / "finetune" / "policy.pt")).eval()
    session = onnxruntime.InferenceSession(str(tmp_path / "policy.onnx"))
    observations = np.random.default_rng(0).normal(size=(8, model.observation_size)).astype(np.float32)
    onnx_actions = session.run(None, {"observation": observations})[0]
    torch_actions = model.action_mean(torch.as_tensor(observations)).detach().numpy()
    np.testing.assert_allclose(onnx_actions, torch_actions, atol=1e-4)


def test_max_velocity_protocol_on_the_mbc_finds_its_command_limit():
    """The MBC follows forward commands up to 1.0 m/s (its clip): the ramp finds about that."""
    row = evaluate(["mbc"], ("max_velocity",), seeds=1, workers=1).rows[0]
    assert 0.85 < row["metric"] < 1.15
