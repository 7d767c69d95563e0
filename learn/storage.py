"""DAgger's aggregated dataset: one shard file per iteration on disk, all of them in memory for fitting.

A shard is written atomically (to a temporary name, flushed to disk, then renamed), so a run killed at
any moment leaves either the whole shard or none; a resumed run reloads every shard it finds and
never loses a labelled sample.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from mbc.errors import ConfigError

_SHARD = re.compile(r"shard_(\d{5})\.npz$")


def output_directory(path: Path, option: str) -> Path:
    """`path`, created if missing; a `ConfigError` naming `option` when it is a file or cannot be created."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise ConfigError(f"{option} {path} is a file; give a directory (it is created if missing)")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise ConfigError(f"cannot create {option} {path}: {error.strerror}") from error
    return path


def atomic_write(path: Path, write) -> None:
    """Call `write(file)` on a temporary file beside `path`, flush it to disk, then rename it to `path`."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    with open(tmp, "wb") as file:
        write(file)
        file.flush()
        os.fsync(file.fileno())
    os.replace(tmp, path)


class LabelledDataset:
    """(observation, expert action, assumption monitors) samples, aggregated over iterations."""

    def __init__(self, directory: str | Path, max_samples: int | None = None) -> None:
        self.directory = Path(directory)
        self.max_samples = max_samples
        self.observations: list[np.ndarray] = []
        self.actions: list[np.ndarray] = []
        self.monitors: list[np.ndarray] = []
        self.iterations: list[int] = []
        self.visited: dict[int, int] = {}
        """States visited (labelled or not) in each iteration's rollout."""

    def shard_path(self, iteration: int) -> Path:
        return self.directory / f"shard_{iteration:05d}.npz"

    def shards_on_disk(self) -> list[int]:
        """Iterations whose shard exists, in order."""
        if not self.directory.is_dir():
            return []
        return sorted(int(m.group(1)) for p in self.directory.iterdir() if (m := _SHARD.match(p.name)))

    def add(self, iteration: int, observations: np.ndarray, actions: np.ndarray, monitors: np.ndarray,
            visited: int) -> None:
        """Write iteration's shard atomically, then add it to memory; `visited` counts the rollout's states."""
        if not (len(observations) == len(actions) == len(monitors)):
            raise ConfigError("observations, actions and monitors must have the same length")
        arrays = {"observations": observations.astype(np.float32), "actions": actions.astype(np.float32),
                  "monitors": monitors.astype(np.float32), "visited": np.array(visited)}
        atomic_write(self.shard_path(iteration), lambda file: np.savez(file, **arrays))
        self._append(iteration, arrays)

    def load(self, iterations: list[int]) -> None:
        """Read the shards of `iterations` into memory (after a restart)."""
        for iteration in iterations:
            with np.load(self.shard_path(iteration)) as shard:
                self._append(iteration, {k: shard[k] for k in ("observations", "actions", "monitors", "visited")})

    def _append(self, iteration: int, arrays: dict[str, np.ndarray]) -> None:
        self.iterations.append(iteration)
        self.visited[iteration] = int(arrays["visited"])
        self.observations.append(arrays["observations"])
        self.actions.append(arrays["actions"])
        self.monitors.append(arrays["monitors"])
        while self.max_samples is not None and len(self.iterations) > 1 and len(self) > self.max_samples:
            for parts in (self.iterations, self.observations, self.actions, self.monitors):
                parts.pop(0)  # the oldest shard leaves memory (it stays on disk)

    def __len__(self) -> int:
        return sum(len(o) for o in self.observations)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(observations, actions, monitors) of every sample in memory, concatenated."""
        if not self.observations:
            raise ConfigError("the dataset is empty")
        return np.concatenate(self.observations), np.concatenate(self.actions), np.concatenate(self.monitors)
