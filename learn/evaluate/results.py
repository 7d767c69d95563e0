"""Evaluation results: every job's raw figures, and per protocol a table laid out like the paper's
(one row per controller and shift; success, falls and the protocol's figures as mean +- 95% CI over
seeds), as markdown, CSV and JSON."""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property

from learn.evaluate.gait import SCALARS
from learn.evaluate.metrics import mean_ci95
from learn.evaluate.protocols import parse_protocol

FIGURES: dict[str, list[tuple[str, str]]] = {
    "flat": [("commands tracked", "metric")],
    "course": [("levels passed", "metric"), ("time to the end [s]", "time_to_end_s")],
    "incline": [("speed error [% of 0.5 m/s]", "metric"), ("heading drift [deg]", "heading_drift_deg")],
    "uneven": [("distance [m]", "metric")],
    "step_slip": [("slid on the board [m]", "metric")],
    "sand": [("distance [m]", "metric"), ("speed p2p in a cycle [m/s]", "speed_oscillation_mps"),
             ("yaw p2p in a cycle [deg]", "yaw_oscillation_deg")],
    "random_velocity": [("tracking return (46 = perfect)", "metric"), ("trajectories fallen", "fall_share")],
    "max_velocity": [("highest speed held [m/s]", "metric")],
    "mar": [("flat: w < 0.2 w0", "flat_violated"), ("flat: w > 0.8 w0", "flat_holds"),
            ("uphill: w < 0.2 w0", "uphill_violated"), ("uphill: w > 0.8 w0", "uphill_holds")],
    "gait": [("step length [m]", "step_length_m"), ("step width [m]", "step_width_m"),
             ("step duration [s]", "step_duration_s"), ("swing apex [m]", "swing_apex_m"),
             ("length asymmetry", "length_symmetry"), ("joint cycle RMS to MBC [rad]", "to_mbc_joint_cycle_rms_rad"),
             ("step length vs MBC", "to_mbc_step_length_m"), ("apex vs MBC", "to_mbc_swing_apex_m")],
}
"""Per kind of protocol: (column header, key of the job's raw figures)."""
assert set(SCALARS) <= {key for _, key in FIGURES["gait"]}


def figure_kind(protocol: str) -> str:
    kind, _ = parse_protocol(protocol)
    if kind.startswith("course"):
        return "course"
    return "incline" if kind.startswith(("uphill", "downhill")) else kind


@dataclass
class Results:
    """Raw job figures (each with its controller label, protocol, seed and shift) and their tables."""

    raw: list[dict] = field(default_factory=list)

    @property
    def protocols(self) -> list[str]:
        return list(dict.fromkeys(r["protocol"] for r in self.raw))

    @cached_property
    def rows(self) -> list[dict]:
        """One aggregated row per (protocol, controller, shift), in order of first appearance (computed once:
        `raw` is complete when a `Results` is made)."""
        groups: dict[tuple, list[dict]] = {}
        for r in self.raw:
            groups.setdefault((r["protocol"], r["controller"], r["shift"]), []).append(r)
        rows = []
        for (protocol, controller, shift), runs in groups.items():
            row = {"protocol": protocol, "controller": controller, "shift": shift, "runs": len(runs),
                   "successes": sum(bool(r["success"]) for r in runs), "falls": sum(bool(r["fell"]) for r in runs),
                   "seeds": [r["seed"] for r in runs]}
            for _, key in FIGURES[figure_kind(protocol)]:
                row[key], row[f"{key}_ci"] = mean_ci95([r.get(key, math.nan) for r in runs])
            rows.append(row)
        return rows

    def table(self, protocol: str | None = None) -> str:
        """Markdown of one protocol's rows (of every protocol, one table each, without `protocol`)."""
        if protocol is None:
            return "\n\n".join(f"### {p}\n\n{self.table(p)}" for p in self.protocols)
        figures = FIGURES[figure_kind(protocol)]
        lines = ["| controller | shift | success | falls | " + " | ".join(h for h, _ in figures) + " |",
                 "|---|---|---|---|" + "---|" * len(figures)]
        for row in (r for r in self.rows if r["protocol"] == protocol):
            cells = [_mean_ci(row[key], row[f"{key}_ci"]) for _, key in figures]
            lines.append(f"| {row['controller']} | {row['shift']} | {row['successes']}/{row['runs']} | "
                         f"{row['falls']} | " + " | ".join(cells) + " |")
        return "\n".join(lines)

    def summary(self, shift: str = "nominal") -> str:
        """Markdown, one row per protocol and one column per controller: successes / runs and the
        protocol's first figure (the comparison at a glance)."""
        return self._matrix([r for r in self.rows if r["shift"] == shift], "controller")

    def shift_summary(self, controller: str) -> str:
        """Markdown, one row per protocol and one column per shift, for one controller (its transfer)."""
        return self._matrix([r for r in self.rows if r["controller"] == controller], "shift")

    def _matrix(self, rows: list[dict], column: str) -> str:
        columns = list(dict.fromkeys(r[column] for r in rows))
        lines = ["| protocol (figure) | " + " | ".join(columns) + " |", "|---|" + "---|" * len(columns)]
        for protocol in self.protocols:
            header, key = FIGURES[figure_kind(protocol)][0]
            cells = {r[column]: f"{r['successes']}/{r['runs']}, {_mean_ci(r[key], r[f'{key}_ci'])}"
                     for r in rows if r["protocol"] == protocol}
            lines.append(f"| {protocol} ({header}) | " + " | ".join(cells.get(c, "") for c in columns) + " |")
        return "\n".join(lines)

    def csv(self, protocol: str) -> str:
        rows = [r for r in self.rows if r["protocol"] == protocol]
        out = io.StringIO()
        writer = csv.DictWriter(out, fieldnames=[k for k in rows[0] if k != "seeds"], extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
        return out.getvalue()

    def to_json(self) -> str:
        """Every raw figure with its seed and shift, and the aggregated rows (NaN written as null)."""
        return json.dumps(_finite({"raw": self.raw, "rows": self.rows}), indent=1)

    @classmethod
    def from_json(cls, text: str) -> Results:
        """The raw figures of `to_json`'s text (a top-level null read back as NaN); the rows are recomputed."""
        raw = json.loads(text)["raw"]
        return cls([{k: math.nan if v is None else v for k, v in r.items()} for r in raw])

    @classmethod
    def merged(cls, parts: Sequence[Results], labels: Callable[[list[str]], dict[str, str]]) -> tuple[Results, int]:
        """One `Results` of evaluations run apart (each training seed as its run finished, say), and how many jobs a
        later part replaced: a job (path, protocol, seed, shift) in several parts is the last part's (re-evaluated,
        say, with a figure added). Controllers are relabelled over all parts by `labels` (paths -> labels), since
        two runs may each have called a different `.../policy.pt` 'policy'."""
        jobs: dict[tuple, dict] = {}
        replaced = 0
        for part in parts:
            for r in part.raw:
                job = (r["path"], r["protocol"], r["seed"], r["shift"])
                replaced += job in jobs
                jobs[job] = dict(r)
        raw = list(jobs.values())
        names = labels(list(dict.fromkeys(r["path"] for r in raw)))
        for r in raw:
            r["controller"] = names[r["path"]]
        return cls(raw), replaced


def _mean_ci(mean: float, ci: float) -> str:
    if not math.isfinite(mean):
        return "-"
    return f"{mean:.3g} +- {ci:.2g}" if math.isfinite(ci) else f"{mean:.3g}"


def _finite(value):
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value
