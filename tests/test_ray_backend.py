"""The Ray backend (`make_vec_env(..., backend="ray")`), on a local cluster inside a network namespace with only
loopback (`unshare -n`, as root: CI runs as root), so that none of Ray's traffic can leave 127.0.0.1:
the same rollouts as the process backend, a killed actor replaced without a lost sample, every socket on
loopback, and a short fine-tuning through Ray actors that improves its reward like the process backend's.
Outside such a namespace the project refuses to start a local cluster (also tested)."""

import ipaddress
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from mbc.errors import ConfigError

ROOT = Path(__file__).resolve().parents[1]
ray = pytest.importorskip("ray", reason="the Ray backend is an optional extra: pip install -e '.[ray]'")


def _can_unshare() -> bool:
    return os.geteuid() == 0 and shutil.which("unshare") is not None and subprocess.run(
        ["unshare", "-n", "true"], capture_output=True).returncode == 0


needs_namespace = pytest.mark.skipif(not _can_unshare(), reason="needs root and unshare -n (a network namespace)")


@pytest.fixture(scope="module")
def scenarios(tmp_path_factory):
    work = tmp_path_factory.mktemp("ray")
    result = subprocess.run(["unshare", "-n", sys.executable, str(ROOT / "tests" / "ray_netns.py"), str(work)],
                            cwd=ROOT, capture_output=True, text=True, timeout=900)
    lines = [line for line in result.stdout.splitlines() if line.startswith("RESULT ")]
    assert result.returncode == 0 and lines, result.stdout[-3000:] + result.stderr[-3000:]
    return json.loads(lines[-1][len("RESULT "):])


@needs_namespace
def test_the_ray_backend_gives_the_process_backends_rollouts(scenarios):
    assert scenarios["identical"]["differing_fields"] == []
    assert scenarios["identical"]["samples"] == [2 * 2 * 40, 2 * 2 * 40]


@needs_namespace
def test_a_killed_actor_is_replaced_and_its_rollout_collected_again(scenarios):
    killed = scenarios["killed"]
    assert killed["killed_during_collect"]  # the kill landed while its rollout was running
    assert killed["samples"] == killed["expected_samples"] and killed["finite"]
    assert killed["killed_pid"] not in killed["pids_after"]  # a new process took its place
    assert killed["pids_before"][1] == killed["pids_after"][1]  # the other actor was not touched
    assert killed["next_samples"] == 2 * 2 * 20  # and the run goes on


@needs_namespace
def test_the_evaluation_runs_its_jobs_as_ray_tasks(scenarios):
    assert scenarios["evaluation"] == {"successes": [True, True], "errors": [None, None]}


@needs_namespace
def test_every_socket_of_the_cluster_is_on_loopback(scenarios):
    assert scenarios["interfaces"] == ["lo"]
    addresses = {address for pair in scenarios["sockets"] for address in pair}
    assert addresses, "no socket seen: the check would prove nothing"
    for address in addresses:
        ip = ipaddress.ip_address(address)
        ip = getattr(ip, "ipv4_mapped", None) or ip  # ::ffff:127.0.0.1 is IPv4's loopback seen by an IPv6 socket
        assert ip.is_loopback or ip.is_unspecified, address  # unspecified (a wildcard bind) has only lo here


@needs_namespace
def test_a_short_finetuning_through_ray_improves_its_reward(scenarios):
    before, after = scenarios["finetune"]["before"], scenarios["finetune"]["after"]
    assert after > before + 0.05, (before, after)


def test_no_local_cluster_is_started_where_other_interfaces_exist():
    from learn.ray_vec_env import connect, network_interfaces

    if network_interfaces() == ["lo"]:
        pytest.skip("this machine has only loopback: a local cluster would be allowed")
    with pytest.raises(ConfigError, match="refusing to start a local Ray cluster"):
        connect(None)
    assert not ray.is_initialized()
