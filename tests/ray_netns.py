"""The Ray backend's scenarios, run by tests/test_ray_backend.py inside a network namespace with only loopback
(`unshare -n`, as root), where a local Ray cluster's traffic cannot leave 127.0.0.1. Brings loopback up,
starts the cluster (dashboard off) through `learn.ray_vec_env.connect`, runs the scenarios and prints their
figures as one JSON line. Not a test module: it needs the namespace."""

from __future__ import annotations

import dataclasses
import fcntl
import json
import os
import signal
import socket
import struct
import sys
import threading
import time
from pathlib import Path

import numpy as np


def loopback_up() -> None:
    """`ip link set lo up` by ioctl (SIOCGIFFLAGS / SIOCSIFFLAGS, IFF_UP): a new namespace's loopback is down."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        request = struct.pack("16sH", b"lo", 0)
        flags = struct.unpack("16sH", fcntl.ioctl(s, 0x8913, request))[1]
        fcntl.ioctl(s, 0x8914, struct.pack("16sH", b"lo", flags | 0x1))


def _addresses(path: str, ipv6: bool) -> list[tuple[str, str]]:
    """(local, remote) addresses of every socket in a /proc/net table, as IP strings."""
    def ip(hex_address: str) -> str:
        raw = bytes.fromhex(hex_address.split(":")[0])
        if ipv6:
            return socket.inet_ntop(socket.AF_INET6, b"".join(raw[i:i + 4][::-1] for i in range(0, 16, 4)))
        return socket.inet_ntop(socket.AF_INET, raw[::-1])

    rows = Path(path).read_text().splitlines()[1:]
    return [(ip(row.split()[1]), ip(row.split()[2])) for row in rows]


def sockets() -> list[tuple[str, str]]:
    table = []
    for name, ipv6 in (("tcp", False), ("udp", False), ("tcp6", True), ("udp6", True)):
        if Path(f"/proc/net/{name}").exists():
            table += _addresses(f"/proc/net/{name}", ipv6)
    return table


def identical_rollouts() -> dict:
    """The same request on 2 process workers and on 2 Ray actors (no expert: IFM's rollouts, sampled policy)."""
    import torch

    from learn.action import ActionSpace
    from learn.checkpoints import deployable_checkpoint
    from learn.config import EnvConfig
    from learn.observation import ObservationLayout
    from learn.policy import ActorCritic
    from learn.ray_vec_env import RayVecEnv
    from learn.vec_env import ProcessVecEnv, RolloutRequest

    torch.manual_seed(0)
    config = EnvConfig(terrains=("flat", "slope:angle_deg=5"))
    policy = deployable_checkpoint(ActorCritic(ObservationLayout(config.history_length).size), config, ActionSpace())
    requests = [RolloutRequest(policy, 40, seed=3, stochastic=True, label_every=0),
                RolloutRequest(policy, 40, seed=4, stochastic=True, label_every=0, continue_episodes=True)]
    results = {}
    for name, make in (("process", ProcessVecEnv), ("ray", RayVecEnv)):
        with make(config, 2, 2, with_expert=False) as vec_env:
            results[name] = [vec_env.collect(request) for request in requests]
    fields = ("observations", "actions", "rewards", "terminated", "truncated", "log_probs", "values", "last_values")
    differing = [f"{k}:{field}" for k in range(len(requests)) for field in fields
                 if not np.array_equal(getattr(results["process"][k], field), getattr(results["ray"][k], field))]
    return {"differing_fields": differing, "samples": [r.samples for r in results["ray"]]}


KILL_AFTER_S = 0.5
KILLED_ROLLOUT_TICKS = 4000
"""2 x 4,000 ticks per actor take 2-3 s on this machine (400 took 0.3 s, and the kill came after it): the kill
lands mid-rollout, which the scenario reports and the test asserts."""


def killed_actor() -> dict:
    """SIGKILL one actor's process in the middle of a rollout: Ray restarts it, the rollout comes back whole."""
    from learn.action import ActionSpace
    from learn.checkpoints import deployable_checkpoint
    from learn.config import EnvConfig
    from learn.observation import ObservationLayout
    from learn.policy import ActorCritic
    from learn.ray_vec_env import RayVecEnv
    from learn.vec_env import RolloutRequest

    config = EnvConfig(terrains=("flat",))
    policy = deployable_checkpoint(ActorCritic(ObservationLayout(config.history_length).size), config, ActionSpace())
    with RayVecEnv(config, 2, 2, with_expert=False) as vec_env:
        before = vec_env.worker_pids()
        killer = threading.Timer(KILL_AFTER_S, os.kill, (before[0], signal.SIGKILL))
        killer.start()
        start = time.perf_counter()
        rollout = vec_env.collect(RolloutRequest(policy, KILLED_ROLLOUT_TICKS, seed=5, stochastic=True, label_every=0))
        wall = time.perf_counter() - start
        killer.join()
        after = vec_env.worker_pids()
        again = vec_env.collect(RolloutRequest(policy, 20, seed=6, stochastic=True, label_every=0, continue_episodes=True))
    return {"killed_pid": before[0], "pids_before": before, "pids_after": after, "samples": rollout.samples,
            "expected_samples": 2 * 2 * KILLED_ROLLOUT_TICKS, "finite": bool(np.isfinite(rollout.observations).all()),
            "next_samples": again.samples, "collect_wall_s": wall, "killed_during_collect": wall > KILL_AFTER_S}


def evaluation_on_ray() -> dict:
    """`learn.evaluate` with its jobs as Ray tasks: the MBC's 12 s gait run on two seeds."""
    from learn.evaluate import evaluate

    results = evaluate(["mbc"], ["gait"], seeds=2, workers=2, backend="ray")
    return {"successes": [r["success"] for r in results.raw], "errors": [r.get("error") for r in results.raw]}


def short_finetuning(work_dir: Path) -> dict:
    """tests/test_learn_ppo.py's short PPF run from the degraded shipped policy, its rollouts on 2 Ray actors."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import test_learn_ppo as ppo_tests

    from learn.config import WorkerConfig

    config, degraded, env = ppo_tests.degraded_ppf_run(work_dir)
    config = dataclasses.replace(config, workers=WorkerConfig(workers=2, envs_per_worker=1, backend="ray"))
    from learn.finetune import FinetuneRunner

    before = ppo_tests._evaluation_reward(degraded, env)
    after = ppo_tests._evaluation_reward(FinetuneRunner(config).learn(), env)
    return {"before": before, "after": after}


def main() -> None:
    loopback_up()
    from learn.ray_vec_env import connect, network_interfaces

    interfaces = network_interfaces()
    connect(None, num_cpus=2)
    out = {"interfaces": interfaces, "identical": identical_rollouts(), "killed": killed_actor(),
           "evaluation": evaluation_on_ray()}
    if len(sys.argv) > 1:
        out["finetune"] = short_finetuning(Path(sys.argv[1]))
    out["sockets"] = sockets()
    import ray

    ray.shutdown()
    print("RESULT " + json.dumps(out))


if __name__ == "__main__":
    main()
