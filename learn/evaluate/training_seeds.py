"""Results over training seeds: a method's policies, one per training seed, each evaluated on the same evaluation
seeds; per method and protocol, each training seed's success share and mean figure, then their mean and the
half-width of a 95% confidence interval over training seeds (Student's t with n - 1 degrees of freedom: with
three training seeds t = 4.30, an interval that says how little three runs pin down).

    python -m learn.evaluate --groups ppf='runs/ppf_s*/finetune/policy.pt' ifm='runs/ifm_s*/finetune/policy.pt' ...
"""

from __future__ import annotations

import glob
import math
from collections.abc import Sequence

import numpy as np
from scipy import stats

from learn.evaluate.results import FIGURES, Results, figure_kind
from mbc.errors import ConfigError


def parse_groups(specs: Sequence[str]) -> dict[str, list[str]]:
    """'NAME=PATH[,PATH...]' (each path may be a glob pattern) -> {NAME: [paths, sorted per pattern]}."""
    groups: dict[str, list[str]] = {}
    for spec in specs:
        name, sep, paths = spec.partition("=")
        if not sep or not name or not paths:
            raise ConfigError(f"a group is NAME=PATH[,PATH...] (paths may be globs), got {spec!r}")
        if name in groups:
            raise ConfigError(f"group {name!r} given twice")
        members = []
        for pattern in paths.split(","):
            matched = sorted(glob.glob(pattern)) if glob.has_magic(pattern) else [pattern]
            if not matched:
                raise ConfigError(f"group {name!r}: no file matches {pattern!r}")
            members += matched
        groups[name] = members
    return groups


def t_interval(values: Sequence[float]) -> tuple[float, float]:
    """Mean of the finite values and the half-width of its 95% interval, t(0.975, n - 1) s / sqrt n (NaN for n < 2)."""
    finite = np.asarray(values, float)
    finite = finite[np.isfinite(finite)]
    if not len(finite):
        return math.nan, math.nan
    if len(finite) < 2:
        return float(finite.mean()), math.nan
    half = stats.t.ppf(0.975, len(finite) - 1) * finite.std(ddof=1) / math.sqrt(len(finite))
    return float(finite.mean()), float(half)


def seed_rows(results: Results, groups: dict[str, list[str]], shift: str = "nominal") -> list[dict]:
    """Per (protocol, group): the training seeds' success shares and mean first figures, and their t intervals."""
    rows = []
    for protocol in results.protocols:
        _, key = FIGURES[figure_kind(protocol)][0]
        for name, paths in groups.items():
            shares, figures = [], []
            for path in paths:
                runs = [r for r in results.raw if r["path"] == path and r["protocol"] == protocol and r["shift"] == shift]
                if runs:
                    shares.append(np.mean([bool(r["success"]) for r in runs]))
                    values = [r.get(key, math.nan) for r in runs]
                    figures.append(float(np.nanmean(values)) if np.isfinite(values).any() else math.nan)
            success, success_ci = t_interval(shares)
            figure, figure_ci = t_interval(figures)
            rows.append({"protocol": protocol, "group": name, "training_seeds": len(shares), "success_shares": shares,
                         "success": success, "success_ci": success_ci, key: figure, f"{key}_ci": figure_ci,
                         "figures": figures})
    return rows


def seed_table(results: Results, groups: dict[str, list[str]], shift: str = "nominal") -> str:
    """Markdown: a row per protocol, a column per group: success share and first figure, each mean +- 95% CI over
    the group's training seeds."""
    rows = seed_rows(results, groups, shift)
    names = list(groups)
    lines = ["| protocol (figure) | " + " | ".join(f"{n} (n={len(groups[n])})" for n in names) + " |",
             "|---|" + "---|" * len(names)]
    for protocol in results.protocols:
        header, key = FIGURES[figure_kind(protocol)][0]
        cells = []
        for name in names:
            row = next(r for r in rows if r["protocol"] == protocol and r["group"] == name)
            cells.append(f"{_interval(row['success'], row['success_ci'], 2)}; {_interval(row[key], row[f'{key}_ci'], 3)}")
        lines.append(f"| {protocol} (success share; {header}) | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _interval(mean: float, half: float, digits: int) -> str:
    if not math.isfinite(mean):
        return "-"
    return f"{mean:.{digits}g} +- {half:.2g}" if math.isfinite(half) else f"{mean:.{digits}g}"
