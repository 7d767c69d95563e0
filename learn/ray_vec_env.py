"""Rollouts on Ray actors: the `VecEnv` interface over a cluster (`make_vec_env(..., backend="ray")`).

Each `EnvGroup` (its environments and their experts) is one actor of `num_cpus=1` (a group is one
thread: physics, expert and its batched policy forward), so a cluster places as many groups as it has
cores. A `collect` puts the request in the object store once and runs it on every actor; the same
request gives each group the same rollout as in a worker process of `ProcessVecEnv` (the groups are
the same code). An actor whose process dies is restarted by Ray (`max_restarts`) and its pending
rollout run again (`max_task_retries`): the run loses no sample; the restarted group begins fresh
episodes at its request's seed, like a group after a resume.

Security. Started plainly, Ray binds every interface of the machine and probes an outside address to
find its own; this module therefore never starts a cluster on a machine that has any network
interface but loopback. Join your own cluster with `address` (`--ray-address`, e.g. "auto" on a node
of it; docs/cluster.md), or run where only loopback exists (`sudo unshare -n ...`: a network namespace
of its own), where a local cluster is started with its dashboard off.
"""

from __future__ import annotations

import os
import socket

from learn.config import EnvConfig
from learn.curriculum import TerrainCurriculum
from learn.vec_env import EnvGroup, Rollout, RolloutRequest, VecEnv
from mbc.errors import ConfigError


def network_interfaces() -> list[str]:
    """Names of this machine's (this network namespace's) network interfaces."""
    return [name for _, name in socket.if_nameindex()]


def connect(address: str | None, num_cpus: int | None = None) -> None:
    """Join the Ray cluster at `address`, or start a local one (of this machine's cores, or `num_cpus` if more)
    where loopback is the only interface."""
    try:
        import ray
    except ImportError as error:
        raise ConfigError("the Ray backend needs Ray: pip install -e '.[ray]'") from error
    if ray.is_initialized():
        return
    if address is None:
        others = [name for name in network_interfaces() if name != "lo"]
        if others:
            raise ConfigError(
                f"refusing to start a local Ray cluster on a machine with network interfaces {others}: Ray would "
                "listen on them. Start a cluster of your own (`ray start --head ...`, docs/cluster.md) and pass its "
                "address (--ray-address), or run inside a network namespace with only loopback (sudo unshare -n)")
        ray.init(address="local", num_cpus=max(num_cpus or 0, os.cpu_count() or 1), include_dashboard=False,
                 _node_ip_address="127.0.0.1", log_to_driver=False, configure_logging=False)
    else:
        ray.init(address=address, log_to_driver=False, configure_logging=False)


def require_cpus(count: int) -> None:
    """A `ConfigError` unless the cluster has `count` CPUs for actors of one CPU each (else they wait forever)."""
    import ray

    available = ray.cluster_resources().get("CPU", 0.0)
    if available < count:
        raise ConfigError(f"the Ray cluster has {available:g} CPUs, fewer than the {count} actors of one CPU asked "
                          "for: lower --workers.workers or add nodes")


class _GroupActor:
    """An `EnvGroup` in a Ray actor (made remote in `RayVecEnv`: Ray is imported only there)."""

    def __init__(self, config: EnvConfig, indices: list[int], with_expert: bool,
                 curriculum: TerrainCurriculum | None) -> None:
        self.group = EnvGroup(config, indices, with_expert, curriculum)

    def observation_size(self) -> int:
        return self.group.envs[0].observation_size

    def run(self, request: RolloutRequest) -> Rollout:
        return self.group.run(request)

    def pid(self) -> int:
        return os.getpid()


class RayVecEnv(VecEnv):
    """`workers` Ray actors with `envs_per_worker` environments each (`ProcessVecEnv`'s groups, on a cluster)."""

    def __init__(self, config: EnvConfig, workers: int, envs_per_worker: int, with_expert: bool = True,
                 curriculum: TerrainCurriculum | None = None, address: str | None = None) -> None:
        connect(address, num_cpus=None if address else workers)
        require_cpus(workers)
        import ray

        self._ray = ray
        actor = ray.remote(num_cpus=1, max_restarts=-1, max_task_retries=-1)(_GroupActor)
        self.actors = [actor.remote(config, list(range(w * envs_per_worker, (w + 1) * envs_per_worker)), with_expert,
                                    curriculum) for w in range(workers)]
        self.observation_size = ray.get(self.actors[0].observation_size.remote())
        self.num_envs = workers * envs_per_worker

    def collect(self, request: RolloutRequest) -> Rollout:
        request_ref = self._ray.put(request)
        return Rollout.concatenate(self._ray.get([actor.run.remote(request_ref) for actor in self.actors]))

    def worker_pids(self) -> list[int]:
        """The process id of each actor (to watch or, in tests, to kill them)."""
        return self._ray.get([actor.pid.remote() for actor in self.actors])

    def close(self) -> None:
        for actor in self.actors:
            self._ray.kill(actor)
        self.actors = []
