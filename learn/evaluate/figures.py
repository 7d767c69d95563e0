"""PNG figures of an evaluation: per protocol its main figure per controller with 95% intervals; the MAR
weight histograms on flat ground and uphill and the scatter of |z'| against speed error; the gait
cycles of the policies against the MBC's."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from learn.evaluate.gait import CYCLE_SAMPLES
from learn.evaluate.protocols import MAR_REGIONS, MAR_UPHILL_DEG
from learn.evaluate.results import FIGURES, Results, figure_kind
from robots.digit import constants as digit


def write_figures(results: Results, out_dir: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    written = [_protocol_bars(results, protocol, out_dir) for protocol in results.protocols]
    if any(r["protocol"] == "mar" for r in results.raw):
        written += [_mar_histograms(results, out_dir), _mar_scatter(results, out_dir)]
    if any(r["protocol"] == "gait" and r.get("features") for r in results.raw):
        written.append(_gait_cycles(results, out_dir))
    return written


def _protocol_bars(results: Results, protocol: str, out_dir: Path) -> Path:
    import matplotlib.pyplot as plt

    header, key = FIGURES[figure_kind(protocol)][0]
    rows = [r for r in results.rows if r["protocol"] == protocol]
    labels = [r["controller"] if r["shift"] == "nominal" else f"{r['controller']}\n{r['shift']}" for r in rows]
    fig, ax = plt.subplots(figsize=(max(4.5, 0.9 * len(rows) + 1.5), 3.4))
    means = [r[key] for r in rows]
    ax.bar(range(len(rows)), np.nan_to_num(means), yerr=np.nan_to_num([r[f"{key}_ci"] for r in rows]), capsize=3,
           color=["tab:gray" if r["controller"] == "MBC" else "tab:blue" for r in rows])
    for i, r in enumerate(rows):
        ax.annotate(f"{r['successes']}/{r['runs']}", (i, 0), textcoords="offset points", xytext=(0, 3), ha="center",
                    fontsize=8, color="white")
    ax.set_xticks(range(len(rows)), labels, fontsize=8)
    ax.set_ylabel(header)
    ax.set_title(f"{protocol}: mean and 95% CI\n(successes / runs on the bars)", fontsize=9)
    return _save(fig, out_dir / f"{protocol}.png")


def _mar_runs(results: Results) -> dict[str, list[dict]]:
    runs: dict[str, list[dict]] = {}
    for r in results.raw:
        if r["protocol"] == "mar" and r["shift"] == "nominal":
            runs.setdefault(r["controller"], []).append(r)
    return runs


def _mar_histograms(results: Results, out_dir: Path) -> Path:
    import matplotlib.pyplot as plt

    runs = _mar_runs(results)
    fig, axes = plt.subplots(1, len(runs), figsize=(max(5.0, 3.2 * len(runs)), 3.2), squeeze=False, sharey=True)
    edges = np.linspace(0, 1, 21)
    for ax, (controller, rs) in zip(axes[0], runs.items()):
        for terrain, label, colour in (("flat", "flat", "tab:green"), ("slope", f"uphill {MAR_UPHILL_DEG:g} deg", "tab:red")):
            counts = np.sum([r[terrain]["weight_histogram"] for r in rs], axis=0)
            ax.stairs(counts / max(counts.sum(), 1), edges, label=label, color=colour, fill=False, linewidth=1.5)
        for boundary in MAR_REGIONS:
            ax.axvline(boundary, color="k", linestyle=":", linewidth=0.8)
        ax.set_title(controller, fontsize=9)
        ax.set_xlabel("MAR weight w / w0")
    axes[0][0].set_ylabel("share of ticks")
    axes[0][0].legend(fontsize=8)
    fig.suptitle("MAR weight per tick: violated < 0.2 w0 < partial < 0.8 w0 < holds", fontsize=9)
    return _save(fig, out_dir / "mar_weights.png")


def _mar_scatter(results: Results, out_dir: Path) -> Path:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.0, 3.6))
    for controller, rs in _mar_runs(results).items():
        x = np.concatenate([r["scatter"]["abs_com_vz_mps"] for r in rs if "scatter" in r] or [np.zeros(0)])
        y = np.concatenate([r["scatter"]["speed_error_mps"] for r in rs if "scatter" in r] or [np.zeros(0)])
        ax.scatter(x, y, s=8, alpha=0.6, label=controller)
    ax.set_xlabel("|CoM vertical velocity|, gait-cycle mean [m/s]")
    ax.set_ylabel("|forward speed error| [m/s]")
    ax.set_title(f"{MAR_UPHILL_DEG:g} deg uphill at 0.5 m/s, one point per gait cycle", fontsize=9)
    ax.legend(fontsize=8)
    return _save(fig, out_dir / "mar_scatter.png")


def _gait_cycles(results: Results, out_dir: Path) -> Path:
    import matplotlib.pyplot as plt

    joints = [digit.JOINT_NAMES.index(n) for n in digit.JOINT_NAMES[:6]]  # the left leg
    fig, axes = plt.subplots(2, 3, figsize=(10, 5), sharex=True)
    phase = np.linspace(0, 100, CYCLE_SAMPLES)
    cycles: dict[str, list] = {}
    for r in results.raw:
        if r["protocol"] == "gait" and r["shift"] == "nominal" and r.get("features"):
            cycles.setdefault(r["controller"], []).append(np.asarray(r["features"]["joint_cycle"]))
    for controller, cs in cycles.items():
        mean = np.nanmean(cs, axis=0)
        for ax, j in zip(axes.flat, joints):
            ax.plot(phase, mean[:, j], label=controller, linewidth=2.0 if controller == "MBC" else 1.2,
                    color="k" if controller == "MBC" else None)
            ax.set_title(digit.JOINT_NAMES[j], fontsize=9)
    for ax in axes[1]:
        ax.set_xlabel("gait cycle [% from left touchdown]")
    axes[0][0].set_ylabel("angle [rad]")
    axes[0][0].legend(fontsize=8)
    return _save(fig, out_dir / "gait_cycle.png")


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    import matplotlib.pyplot as plt

    plt.close(fig)
    return path
