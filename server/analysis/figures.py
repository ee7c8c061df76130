"""The report's figures, drawn with matplotlib's object API (no pyplot, no global state) from the
stats sections (and, for the scatter, the task-4 trials). Saved as PNG and SVG, deterministic:
fixed sizes and DPI, `svg.hashsalt` fixed, no date in the SVG metadata.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd
from matplotlib.figure import Figure

SIZE = (7.0, 4.0)          # inches
WIDE = (10.0, 4.0)
DPI = 110
COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#17becf")
MARKERS = {"P1": "o", "P2": "s", "P3": "^", "P4": "D", "3dof": "*", "continuous-at-target": "v",
           "none-at-target": "<", "none": "x"}
LABELS = {"trajectory_length": "trajectory length (scene units)", "completion_time": "completion time (s)",
          "helpfulness": "helpfulness (1..7)", "end_error": "end-point error (scene units)"}


def save(fig: Figure, directory: Path, name: str) -> dict[str, Path]:
    """name.png and name.svg in `directory`; returns both paths."""
    directory.mkdir(parents=True, exist_ok=True)
    paths = {"png": directory / f"{name}.png", "svg": directory / f"{name}.svg"}
    with matplotlib.rc_context({"svg.hashsalt": "viestac", "svg.fonttype": "path"}):
        fig.savefig(paths["png"], dpi=DPI, metadata={"Software": None})
        fig.savefig(paths["svg"], metadata={"Date": None, "Creator": None})
    return paths


def _ci_errors(rows: list[dict], key: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Means and asymmetric CI error bars (0 where no CI) of describe() rows."""
    stats = [r[key] if key else r for r in rows]
    means = np.array([s["mean"] if s["mean"] is not None else np.nan for s in stats], dtype=float)
    low = np.array([s["mean"] - s["ci95_low"] if s["ci95_low"] is not None else 0.0 for s in stats], dtype=float)
    high = np.array([s["ci95_high"] - s["mean"] if s["ci95_high"] is not None else 0.0 for s in stats], dtype=float)
    # The CI is over participants' means and the mean over trials: once outlier trials are
    # dropped unevenly the mean can sit just outside the CI; draw no bar below zero length.
    return means, np.clip(np.vstack([low, high]), 0.0, None)


def task1(section: dict) -> Figure:
    fig = Figure(figsize=SIZE, layout="constrained")
    ax = fig.add_subplot()
    rows = section["per_angle"]
    angles = np.array([r["angle"] for r in rows], dtype=float)
    means, err = _ci_errors(rows)
    ax.errorbar(angles, means, yerr=err, fmt="o", color=COLOURS[0], capsize=4, label="mean |deviation| ± 95 % CI")
    trend = section.get("quadratic_trend")
    if trend:
        x = np.linspace(angles.min(), angles.max(), 200)
        ax.plot(x, trend["b0"] + trend["b1"] * x + trend["b2"] * x ** 2, ":", color=COLOURS[1], lw=2,
                label="quadratic trend (OLS)")
    ax.set(xlabel="presented angle (deg)", ylabel="mean absolute deviation (deg)", xticks=angles,
           title="Task 1: contact angle judgement error")
    ax.set_ylim(bottom=0)
    fig.legend(loc="outside lower center", ncol=2, fontsize="small")  # below the axes: hides no error bar
    return fig


def task2_ratings(pairs: dict) -> Figure:
    fig = Figure(figsize=SIZE, layout="constrained")
    ax = fig.add_subplot()
    rows = pairs["per_comparison"]
    x = np.arange(len(rows))
    means, err = _ci_errors(rows)
    ax.axhline(4, color="grey", lw=1, ls="--")
    ax.errorbar(x, means, yerr=err, fmt="o", color=COLOURS[0], capsize=4)
    ax.set(xticks=x, xticklabels=[r["comparison"] for r in rows], ylim=(0.5, 7.5), yticks=range(1, 8),
           ylabel="rating (1 smoother · 4 same · 7 rougher)", xlabel="second vs first texture",
           title="Task 2A: mean rating per comparison ± 95 % CI")
    return fig


def task2_crosstab(crosstab: dict) -> Figure:
    fig = Figure(figsize=(5.5, 4.5), layout="constrained")
    ax = fig.add_subplot()
    counts = np.array(crosstab["counts"], dtype=float)
    image = ax.imshow(counts, cmap="Blues", vmin=0)
    for (i, j), c in np.ndenumerate(counts):
        ax.text(j, i, f"{int(c)}", ha="center", va="center", color="white" if c > counts.max() / 2 else "black")
    ax.set(xticks=range(len(crosstab["detected_hz"])), xticklabels=[f"{v:g}" for v in crosstab["detected_hz"]],
           yticks=range(len(crosstab["actual_hz"])), yticklabels=[f"{v:g}" for v in crosstab["actual_hz"]],
           xlabel="detected frequency (Hz)", ylabel="actual frequency (Hz)", title="Task 2B: actual × detected")
    fig.colorbar(image, ax=ax, label="trials")
    return fig


def task3(part: dict, mode: str, fit_levels: list[int]) -> Figure:
    fig = Figure(figsize=SIZE, layout="constrained")
    ax = fig.add_subplot()
    rows = part["per_level"]
    levels = np.array([r["level"] for r in rows], dtype=float)
    means, err = _ci_errors(rows)
    ax.errorbar(levels, means, yerr=err, fmt="o", color=COLOURS[0], capsize=4, label="mean ± 95 % CI")
    ax.plot([1, 10], [1, 10], color="grey", lw=1, ls="--", label="veridical")
    fit = part.get("fit")
    if fit:
        s = np.linspace(min(fit_levels), max(fit_levels), 100)
        ax.plot(s, fit["a"] * s ** fit["b"], ":", color=COLOURS[1], lw=2,
                label=f"$p = {fit['a']:.3f}\\cdot S^{{{fit['b']:.2f}}}$ (levels {min(fit_levels)}..{max(fit_levels)})")
    response = "named level" if mode == "estimation" else "produced level"
    ax.set(xlabel="stimulus level S", ylabel=response, xticks=range(1, 11), yticks=range(1, 11), xlim=(0.5, 10.5),
           ylim=(0.5, 10.5), title=f"Task 3: magnitude {mode}")
    ax.legend(loc="upper left")
    return fig


def _grouped(ax, rows: list[dict], x_key: str, hue_key: str, measure: str) -> None:
    """Bars of `measure` per x value, one bar per hue value, with CI error bars."""
    xs = list(dict.fromkeys(r[x_key] for r in rows))
    hues = list(dict.fromkeys(r[hue_key] for r in rows))
    width = 0.8 / max(len(hues), 1)
    for k, hue in enumerate(hues):
        sel = [(xs.index(r[x_key]), r) for r in rows if r[hue_key] == hue and r[measure]["mean"] is not None]
        if not sel:
            continue
        means, err = _ci_errors([r for _, r in sel], measure)
        pos = np.array([i for i, _ in sel]) - 0.4 + width * (k + 0.5)
        ax.bar(pos, means, width, yerr=err, capsize=3, color=COLOURS[k % len(COLOURS)], label=str(hue))
    ax.set_xticks(range(len(xs)), [str(x) for x in xs])
    ax.set_ylabel(LABELS[measure])


def _figure_legend(fig: Figure, title: str, loc: str = "outside right upper", ncol: int = 1) -> None:
    """One legend for all panels, outside them (on the right by default: it never hides data)."""
    handles, labels = {}, []
    for ax in fig.axes:
        for h, label in zip(*ax.get_legend_handles_labels()):
            if label not in handles:
                handles[label] = h
                labels.append(label)
    if labels:
        fig.legend([handles[k] for k in labels], labels, title=title, loc=loc, ncol=ncol, fontsize="small")


def task4_device(device: str, part: dict) -> Figure:
    """Trajectory length and completion time per cue (x) and target object (bars), ± 95 % CI."""
    fig = Figure(figsize=WIDE, layout="constrained")
    for i, measure in enumerate(("trajectory_length", "completion_time")):
        ax = fig.add_subplot(1, 2, i + 1)
        _grouped(ax, part["by_cue_object"], "cue", "object", measure)
        ax.set_xlabel("cue")
    _figure_legend(fig, "target")
    fig.suptitle(f"Task 4 ({device}): means per cue and target ± 95 % CI")
    return fig


def task4_helpfulness(devices: dict[str, dict]) -> Figure:
    fig = Figure(figsize=WIDE, layout="constrained")
    for i, (device, part) in enumerate(devices.items()):
        ax = fig.add_subplot(1, len(devices), i + 1)
        _grouped(ax, part["by_cue_object"], "cue", "object", "helpfulness")
        ax.set(ylim=(0, 7.5), title=device, xlabel="cue")
    _figure_legend(fig, "target")
    fig.suptitle("Task 4: helpfulness ratings ± 95 % CI")
    return fig


def task4_devices(devices: dict[str, dict]) -> Figure:
    """Device means (over the guidance trials) of the three measures, ± 95 % CI."""
    fig = Figure(figsize=WIDE, layout="constrained")
    names = list(devices)
    for i, measure in enumerate(("trajectory_length", "completion_time", "helpfulness")):
        ax = fig.add_subplot(1, 3, i + 1)
        means, err = _ci_errors([devices[d] for d in names], measure)
        ax.bar(range(len(names)), np.nan_to_num(means), yerr=err, capsize=4,
               color=[COLOURS[k % len(COLOURS)] for k in range(len(names))])
        ax.set_xticks(range(len(names)), names)
        ax.set_ylabel(LABELS[measure])
    fig.suptitle("Task 4: device comparison (mean over guidance trials ± 95 % CI)")
    return fig


def speed_accuracy(kept: pd.DataFrame) -> Figure:
    """Completion time against trajectory length and against end-point error, one colour per
    device and one marker per cue."""
    fig = Figure(figsize=WIDE, layout="constrained")
    devices = list(dict.fromkeys(kept["device"]))
    for i, other in enumerate(("trajectory_length", "end_error")):
        ax = fig.add_subplot(1, 2, i + 1)
        for (device, cue), g in kept.groupby(["device", "cue"], sort=True):
            g = g[["completion_time", other]].dropna()
            if g.empty:
                continue
            ax.scatter(g[other], g["completion_time"], s=28, alpha=0.8, label=f"{device} {cue}",
                       color=COLOURS[devices.index(device) % len(COLOURS)], marker=MARKERS.get(cue, "x"))
        ax.set(xlabel=LABELS[other], ylabel=LABELS["completion_time"])
    _figure_legend(fig, "device, cue")
    fig.suptitle("Task 4: speed-accuracy (one point per trial)")
    return fig


# --- psychophysics (server/analysis/psychophysics.py) -----------------------------------------

def _panels(count: int) -> tuple[Figure, list]:
    """A figure with one panel per condition: SIZE for one, WIDE rows of up to three for more."""
    cols = min(count, 3)
    rows = -(-count // cols)
    fig = Figure(figsize=SIZE if count == 1 else (WIDE[0], WIDE[1] * rows), layout="constrained")
    return fig, [fig.add_subplot(rows, cols, i + 1) for i in range(count)]


def _axis_label(task: dict) -> str:
    return f"{task['parameter']} ({task['unit']})" if task.get("unit") else str(task["parameter"])


def psy_curves(task: dict) -> Figure:
    """Per condition: the pooled proportion correct per level (area ∝ trials), the pooled fit and
    each participant's fit (thin)."""
    fig, axes = _panels(len(task["conditions"]))
    answer = {"yes-no": 'proportion "yes" (signal trials)',
              "same-different": 'proportion "different" (different pairs)'}.get(task["design"], "proportion correct")
    for ax, cond in zip(axes, task["conditions"]):
        pooled = cond["pooled"]
        pts = pooled["points"]
        levels = np.array([p["level"] for p in pts], dtype=float)
        if len(levels):
            n = np.array([p["n"] for p in pts], dtype=float)
            ax.scatter(levels, [p["p"] for p in pts], s=10 + 190 * n / n.max(), alpha=0.6, color=COLOURS[0],
                       edgecolor="white", label="pooled data (area ∝ trials)")
            x = np.linspace(levels.min(), levels.max(), 200)
            if cond["family"] == "weibull":
                x = np.geomspace(levels.min(), levels.max(), 200)
            for cell in cond["participants"]:
                if cell["fit"]:
                    ax.plot(x, _curve(cell["fit"], x), color="grey", lw=0.7, alpha=0.6)
            if pooled["fit"]:
                f = pooled["fit"]
                ax.plot(x, _curve(f, x), color=COLOURS[1], lw=2, label=f"pooled {f['family']} fit")
                ax.axvline(f["threshold"], color=COLOURS[1], ls=":", lw=1, label="fitted threshold")
            if pooled["procedure_estimate"] is not None:
                ax.axvline(pooled["procedure_estimate"], color=COLOURS[2], ls="--", lw=1,
                           label="procedure's estimate (mean)")
        ax.axhline(task["guess"], color="grey", ls="--", lw=0.8)
        ax.set(ylim=(-0.02, 1.02), xlabel=_axis_label(task), ylabel=answer, title=cond["condition"])
    _figure_legend(fig, "", "outside lower center", 4)
    fig.suptitle(f"{task['task']} ({task['design']}): psychometric functions")
    return fig


def _curve(f: dict, x: np.ndarray) -> np.ndarray:
    from server.psychophysics.functions import FAMILIES

    return FAMILIES[f["family"]].probability(x, f["threshold"], f["slope"], f["guess"], f["lapse"])


def psy_tracks(task: dict, rows: pd.DataFrame) -> Figure:
    """Per condition: each participant's levels trial by trial; filled = correct, open = wrong,
    ring = reversal; the procedure's estimate after the last trial as a short line."""
    fig, axes = _panels(len(task["conditions"]))
    rows = rows[rows["task"] == task["task"]]
    participants = sorted(rows["participant"].unique())
    for ax, cond in zip(axes, task["conditions"]):
        c = rows[rows["condition"] == cond["condition"]]
        for i, (who, g) in enumerate(c.groupby("participant", sort=True)):
            colour = COLOURS[participants.index(who) % len(COLOURS)]
            x = np.arange(1, len(g) + 1)
            y = g["level"].to_numpy(dtype=float)
            ok = g["correct"].astype(bool).to_numpy()
            ax.plot(x, y, color=colour, lw=0.8, alpha=0.7, label=str(who))
            ax.scatter(x[ok], y[ok], s=14, color=colour, zorder=3)
            ax.scatter(x[~ok], y[~ok], s=14, facecolor="white", edgecolor=colour, zorder=3)
            rev = g["reversal"].to_numpy(dtype=bool)
            if rev.any():
                ax.scatter(x[rev], y[rev], s=60, facecolor="none", edgecolor="black", lw=0.8, zorder=4,
                           label="reversal" if i == 0 else None)
            est = next((p["procedure_estimate"] for p in cond["participants"] if p["participant"] == who), None)
            if est is not None:
                ax.hlines(est, len(g) * 0.8, len(g), color=colour, lw=2)
        ax.set(xlabel="trial", ylabel=_axis_label(task), title=cond["condition"])
    _figure_legend(fig, "participant (● correct, ○ wrong)", "outside lower center", 6)
    fig.suptitle(f"{task['task']} ({task['design']}): tracks")
    return fig


def psy_confusion(task: dict, cond: dict) -> Figure:
    fig = Figure(figsize=(5.5, 4.5), layout="constrained")
    ax = fig.add_subplot()
    info = cond["pooled"]["information"]
    counts = np.array(info["confusion"], dtype=float)
    image = ax.imshow(counts, cmap="Blues", vmin=0)
    for (i, j), c in np.ndenumerate(counts):
        ax.text(j, i, f"{int(c)}", ha="center", va="center", color="white" if c > counts.max() / 2 else "black")
    ticks = range(len(info["labels"]))
    ax.set(xticks=ticks, xticklabels=info["labels"], yticks=ticks, yticklabels=info["labels"], xlabel="answer",
           ylabel="stimulus", title=f"{task['task']} {cond['condition']}: IT {info['bits']:.2f} bits "
                                    f"(corrected {info['corrected']:.2f})")
    fig.colorbar(image, ax=ax, label="trials")
    return fig
