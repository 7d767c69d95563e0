"""What a newcomer's mistakes on the command lines give: a clear refusal naming the option and its valid values,
before any work is done (never a traceback, a torch message or a silently substituted default)."""

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from learn.config import WorkerConfig
from learn.evaluate import evaluate
from learn.finetune import SCRATCH_GAMMA, SCRATCH_LAM, SCRATCH_START_LEVEL, FinetuneConfig
from learn.policy import load_checkpoint
from learn.storage import output_directory
from mbc.errors import ConfigError

ROOT = Path(__file__).resolve().parents[1]


def _main_job():
    spec = importlib.util.spec_from_file_location("main_job", ROOT / "examples" / "distill_and_finetune.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["main_job"] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def test_a_file_that_is_not_a_policy_says_what_a_policy_checkpoint_is():
    with pytest.raises(ConfigError) as error:
        load_checkpoint(ROOT / "README.md")
    assert "README.md is not a policy checkpoint: a policy checkpoint is the policy.pt" in str(error.value)
    assert "weights_only" not in str(error.value) and "Unsupported operand" not in str(error.value)


def test_the_main_job_refuses_bad_iterations_and_seeds_before_any_work(tmp_path):
    job = _main_job()
    for args, message in ((dict(iterations=-3), "--iterations must be >= 1"), (dict(iterations=0), "--iterations must be >= 1"),
                          (dict(evaluation_seeds=-1), "--evaluation-seeds must be >= 0"),
                          (dict(heading_hold=-0.1), "--heading-hold must be >= 0"),
                          (dict(lin_vel_sigma=0.0), "--lin-vel-sigma must be positive"),
                          (dict(yaw_rate_sigma=-0.05), "--yaw-rate-sigma must be positive"),
                          (dict(mean_vel_tracking=-1.0), "--mean-vel-tracking must be >= 0"),
                          (dict(method="ifm", regularize_true_observations=True), "ifm has none"),
                          (dict(terrain_kinds=("flat", "sand")), "unknown terrain kind 'sand'; valid: .*'soft'"),
                          (dict(terrain_kinds=()), "needs at least one kind"),
                          (dict(heading_hold=0.1), "--heading-hold needs --stage all")):
        with pytest.raises(ConfigError, match=message):
            job.main(job.Args(run_dir=tmp_path / "run", **args))
    assert not (tmp_path / "run").exists()  # refused before the run directory was made


def test_the_main_job_refuses_an_init_policy_it_cannot_start_from_before_any_work(tmp_path):
    job = _main_job()
    observing = tmp_path / "observing.pt"  # a checkpoint whose policy observes its heading error
    checkpoint = load_checkpoint(ROOT / "policies" / "distilled.pt")
    torch.save(checkpoint | {"observe_heading_error": True}, observing)
    for args, message in ((dict(stage="all", init_policy=observing), "--init-policy is the start of --stage finetune"),
                          (dict(init_policy=observing), "observing.pt was trained with the heading error"),
                          (dict(init_policy=ROOT / "policies" / "distilled.pt", heading_hold=0.1),
                           "--heading-hold needs --stage all or an --init-policy"),
                          (dict(init_policy=ROOT / "README.md"), "README.md is not a policy checkpoint"),
                          (dict(init_policy=tmp_path / "none.pt"), "no policy checkpoint at")):
        with pytest.raises(ConfigError, match=message):
            job.main(job.Args(run_dir=tmp_path / "run", **args))
    assert not (tmp_path / "run").exists()


def test_the_main_job_fine_tunes_the_init_policy_it_is_given(tmp_path, monkeypatch):
    job = _main_job()
    observing = tmp_path / "observing.pt"
    torch.save(load_checkpoint(ROOT / "policies" / "distilled.pt") | {"observe_heading_error": True}, observing)
    configs = []

    class Built(Exception):
        pass

    def runner(config):
        configs.append(config)
        raise Built

    monkeypatch.setattr(job, "FinetuneRunner", runner)
    with pytest.raises(Built):
        job.main(job.Args(run_dir=tmp_path / "run", evaluation_seeds=0, method="fullreg", init_policy=observing,
                          heading_hold=0.1, lin_vel_sigma=0.05, yaw_rate_sigma=0.1, mean_vel_tracking=1.0))
    (config,) = configs
    assert config.init_policy == observing and config.env.observe_heading_error
    assert config.env.expert_heading_correction_per_step_rad == 0.1
    assert (config.env.lin_vel_tracking_sigma, config.env.ang_vel_tracking_sigma) == (0.05, 0.1)
    assert config.env.mean_vel_tracking_weight == 1.0


def test_the_main_job_gives_purerl_its_from_scratch_settings_and_keeps_explicit_ones(tmp_path, monkeypatch):
    job = _main_job()
    configs = []

    class Built(Exception):
        pass

    def runner(config):
        configs.append(config)
        raise Built

    monkeypatch.setattr(job, "FinetuneRunner", runner)
    for kwargs in (dict(method="purerl"), dict(method="ppf"), dict(method="purerl", gamma=0.99, start_level=3)):
        with pytest.raises(Built):
            job.main(job.Args(run_dir=tmp_path / "run", evaluation_seeds=0, **kwargs))
    purerl, ppf, explicit = ((c.ppo.gamma, c.ppo.lam, c.curriculum.initial_max_level) for c in configs)
    assert purerl == (SCRATCH_GAMMA, SCRATCH_LAM, SCRATCH_START_LEVEL) == (0.9975, 0.987, 0)
    assert ppf == (0.99, 0.95, 5) and explicit == (0.99, SCRATCH_LAM, 3)


def test_configs_refuse_values_outside_their_range_with_the_valid_ones():
    with pytest.raises(ConfigError, match="label_every must be >= 1 .* got 0"):
        FinetuneConfig(method="ppf", label_every=0)
    FinetuneConfig(method="ifm", label_every=0)  # no expert: nothing to label
    with pytest.raises(ConfigError, match="unknown method 'magic'; valid"):
        FinetuneConfig(method="magic")
    with pytest.raises(ConfigError, match="iterations and steps_per_env must be >= 1"):
        FinetuneConfig(iterations=-3)
    with pytest.raises(ConfigError, match="got workers=-1, envs_per_worker=8"):
        WorkerConfig(workers=-1)
    for kwargs, message in ((dict(seeds=0), "seeds must be >= 1"), (dict(workers=0), "workers must be >= 1")):
        with pytest.raises(ConfigError, match=message):
            evaluate(["mbc"], ["flat"], **{"seeds": 1, **kwargs})


def test_run_and_output_directories_that_are_files_are_refused(tmp_path):
    a_file = tmp_path / "notes.txt"
    a_file.write_text("not a directory")
    with pytest.raises(ConfigError, match="--out .*notes.txt is a file; give a directory"):
        output_directory(a_file, "--out")
    assert output_directory(tmp_path / "new" / "dir", "--out").is_dir()
    result = subprocess.run([sys.executable, "-m", "learn.evaluate", "--out", str(a_file), "--protocols", "flat"],
                            cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert result.returncode == 2 and "is a file; give a directory" in result.stderr and "Traceback" not in result.stderr
