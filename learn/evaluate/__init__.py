"""The paper's evaluation protocols (and more) for any controller: the MBC or a policy file, in the
nominal simulator or under a domain shift, in parallel over processes; tables (markdown, CSV), raw
figures (JSON) and PNG figures.

    python -m learn.evaluate --controllers mbc policies/distilled.pt --protocols uphill_16 max_velocity
    python -m learn.evaluate --controllers mbc --shifts nominal link_mass sensor_latency --out runs/eval

Protocols: `learn.evaluate.protocols`; shifts: `learn.evaluate.shifts`; metrics: `learn.evaluate.metrics`;
gait features: `learn.evaluate.gait`.
"""

from __future__ import annotations

import multiprocessing
import os
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from tqdm import tqdm

from learn.evaluate.gait import GaitFeatures, gait_distance
from learn.evaluate.metrics import sustained_velocity
from learn.evaluate.protocols import DEFAULT_PROTOCOLS, Job, make_controller, parse_protocol, run_job
from learn.evaluate.results import Results
from learn.evaluate.shifts import SHIFTS, get_shift
from learn.storage import output_directory
from mbc.errors import ConfigError

__all__ = ["DEFAULT_PROTOCOLS", "SHIFTS", "Results", "check_protocols", "controller_labels", "evaluate",
           "sustained_velocity"]


def check_protocols(names: Sequence[str]) -> None:
    """Raise `ConfigError` listing the valid protocols for any unknown name."""
    for name in names:
        parse_protocol(name)


def controller_labels(specs: Sequence[str]) -> dict[str, str]:
    """'MBC' for 'mbc', a policy's file stem, or its path where two stems would be the same."""
    stems = [s if s == "mbc" else Path(s).stem for s in specs]
    return {s: "MBC" if s == "mbc" else (stem if stems.count(stem) == 1 else str(Path(s).with_suffix("")))
            for s, stem in zip(specs, stems)}


def evaluate(controllers: Sequence[str], protocols: Sequence[str] = DEFAULT_PROTOCOLS, seeds: int = 5,
             workers: int | None = None, shifts: Sequence[str] = ("nominal",), progress: bool = False,
             backend: str = "process", ray_address: str | None = None) -> Results:
    """Every (controller, protocol, seed, shift), in parallel over `workers` processes (default: every core), or as
    tasks of a Ray cluster (`backend="ray"`, `learn.ray_vec_env.connect`: one core each).

    The gait protocol measures each gait's distance from the MBC's on the same seed and shift (the MBC's
    gait is run for that when 'mbc' is not among the controllers)."""
    if seeds < 1:
        raise ConfigError(f"seeds must be >= 1, got {seeds}")
    if workers is not None and workers < 1:
        raise ConfigError(f"workers must be >= 1 (default: every core), got {workers}")
    check_protocols(protocols)
    for name in shifts:
        get_shift(name)
    for spec in controllers:
        if spec != "mbc":
            make_controller(spec)  # a clear error before any work for a path that is not a policy
    jobs = [Job(spec, protocol, seed, shift) for spec in controllers for shift in shifts for protocol in protocols
            for seed in range(seeds)]
    reference = [Job("mbc", "gait", seed, shift) for shift in shifts for seed in range(seeds)
                 if "gait" in protocols and "mbc" not in controllers]
    if backend not in ("process", "ray"):
        raise ConfigError(f"unknown backend {backend!r}; valid: ['process', 'ray']")
    processes = workers or os.cpu_count() or 1
    outcomes = (_run_on_ray(jobs + reference, processes, progress, ray_address) if backend == "ray"
                else _run(jobs + reference, processes, progress))
    errors = [(job, outcome["error"]) for job, outcome in zip(jobs + reference, outcomes) if "error" in outcome]
    if errors:
        warnings.warn(f"{len(errors)} of {len(outcomes)} jobs raised (counted as failures), e.g. {errors[0][0]}: "
                      f"{errors[0][1]}", stacklevel=2)
    labels = controller_labels(list(controllers))
    raw = [{"controller": labels[job.controller], "path": job.controller, "protocol": job.protocol, "seed": job.seed,
            "shift": job.shift, **outcome} for job, outcome in zip(jobs, outcomes)]
    mbc_gaits = {(job.seed, job.shift): outcome.get("features") for job, outcome in zip(jobs + reference, outcomes)
                 if job.controller == "mbc" and job.protocol == "gait"}
    for r in raw:
        if r["protocol"] == "gait" and r.get("features") and mbc_gaits.get((r["seed"], r["shift"])):
            distance = gait_distance(_features(r["features"]), _features(mbc_gaits[(r["seed"], r["shift"])]))
            r.update({f"to_mbc_{k}": v for k, v in distance.items()})
    return Results(raw)


def _features(data: dict) -> GaitFeatures:
    return GaitFeatures(**{**data, "joint_cycle": np.asarray(data["joint_cycle"], float)})


def _run_on_ray(jobs: list[Job], workers: int, progress: bool, address: str | None) -> list[dict]:
    """The jobs as Ray tasks of one core each, retried if their worker dies; results in the jobs' order."""
    from learn.ray_vec_env import connect

    connect(address, num_cpus=None if address else workers)
    import ray

    task = ray.remote(num_cpus=1, max_retries=3)(run_job)
    pending = {task.remote(job): k for k, job in enumerate(jobs)}
    outcomes: list[dict] = [{}] * len(jobs)
    with tqdm(total=len(jobs), desc="evaluating (ray)", unit="episode set", disable=not progress) as bar:
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            outcomes[pending.pop(done[0])] = ray.get(done[0])
            bar.update()
    return outcomes


def _run(jobs: list[Job], workers: int, progress: bool) -> list[dict]:
    bar = tqdm(total=len(jobs), desc="evaluating", unit="episode set", disable=not progress)
    if workers > 1 and len(jobs) > 1:
        with multiprocessing.get_context("spawn").Pool(min(workers, len(jobs))) as pool:
            outcomes = []
            for outcome in pool.imap(run_job, jobs, chunksize=1):
                outcomes.append(outcome)
                bar.update()
    else:
        outcomes = []
        for job in jobs:
            outcomes.append(run_job(job))
            bar.update()
    bar.close()
    return outcomes


def write_outputs(results: Results, out_dir: Path, figures: bool = True) -> list[Path]:
    """Per protocol NAME.md and NAME.csv, results.json with every raw figure and seed, and the PNG figures."""
    out_dir = output_directory(out_dir, "--out")
    written = []
    for protocol in results.protocols:
        for suffix, text in ((".md", results.table(protocol) + "\n"), (".csv", results.csv(protocol))):
            path = out_dir / f"{protocol}{suffix}"
            path.write_text(text)
            written.append(path)
    (out_dir / "results.json").write_text(results.to_json())
    shifts = list(dict.fromkeys(r["shift"] for r in results.raw))
    controllers = list(dict.fromkeys(r["controller"] for r in results.raw))
    summaries = [f"### {shift}\n\n{results.summary(shift)}" for shift in shifts]
    if len(shifts) > 1:
        summaries += [f"### {controller} under each shift\n\n{results.shift_summary(controller)}" for controller in controllers]
    (out_dir / "summary.md").write_text("\n\n".join(summaries) + "\n")
    written += [out_dir / "results.json", out_dir / "summary.md"]
    if figures:
        from learn.evaluate.figures import write_figures

        written += write_figures(results, out_dir)
    return written
