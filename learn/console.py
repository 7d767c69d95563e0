"""What a long run prints: one short line per iteration with the figures a user watches, and a summary at
the end. Everything else goes to TensorBoard and the run directory (`scalars.jsonl`)."""

from __future__ import annotations

import json
import math
from pathlib import Path


def iteration_line(iteration: int, total: int, figures: dict[str, str]) -> str:
    """'it 12/150 | samples 76,800 | steps/s 2,810 | ...': the iteration (counted from 1) and `figures` in order."""
    return " | ".join([f"it {iteration + 1}/{total}", *(f"{name} {value}" for name, value in figures.items())])


def number(value: float, digits: int = 3) -> str:
    """A figure for the console: thousands separated, `digits` significant digits, '-' when not a number."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    if abs(value) >= 1000:
        return f"{value:,.0f}"
    return f"{value:.{digits}g}"


def append_scalars(path: Path, iteration: int, scalars: dict[str, float]) -> None:
    """One JSON line per iteration with every scalar (what TensorBoard has, readable without it)."""
    with path.open("a") as file:
        file.write(json.dumps({"iteration": iteration, **{k: float(v) for k, v in scalars.items()}}) + "\n")
