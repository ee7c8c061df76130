"""The report card's figures, drawn from stats.json's content only, as inline SVG text
(matplotlib's object API, deterministic: fixed sizes, `svg.hashsalt`, no date). Each figure names
the literature sources of the bands it draws (server/psychophysics/literature.py)."""

from __future__ import annotations

import io

import matplotlib
import numpy as np
from matplotlib.figure import Figure

from server.analysis.figures import COLOURS
from server.psychophysics import literature

SIZE = (10.0, 4.0)
BAND = {"color": "#999999", "alpha": 0.25, "lw": 0}
DISCRIMINATION = ("amplitude_jnd_db", "frequency_weber", "texture_weber", "stiffness_weber", "jnd",
                  "change_threshold")


def svg(fig: Figure) -> str:
    buffer = io.StringIO()
    with matplotlib.rc_context({"svg.hashsalt": "viestac", "svg.fonttype": "path"}):
        fig.savefig(buffer, format="svg", metadata={"Date": None, "Creator": None})
    text = buffer.getvalue()
    return text[text.index("<svg"):]  # inline: no XML declaration or doctype


def _measures(stats: dict, keys) -> dict[str, list[tuple[str, str, dict]]]:
    """measure key → [(model, part, measure row)] in device order."""
    out: dict[str, list] = {}
    for c in stats["devices"]:
        for p in c["parts"]:
            for m in p["measures"]:
                if m["measure"] in keys:
                    out.setdefault(m["measure"], []).append((c["model"], p["part"], m))
    return out


def _errorbar(ax, x, m: dict, colour, label=None, marker="o"):
    ci = m["ci95"]
    err = None if ci is None else [[max(m["value"] - ci[0], 0.0)], [max(ci[1] - m["value"], 0.0)]]
    ax.errorbar([x], [m["value"]], yerr=err, fmt=marker, color=colour, capsize=4, label=label)


def detection_rows(stats: dict) -> list[tuple[str, str, dict]]:
    """The detection thresholds the figure draws: those with a carrier, within the tested levels."""
    rows = _measures(stats, ("threshold",)).get("threshold", [])
    return [r for r in rows if r[1] == "detection" and r[2].get("carrier_hz") and r[2]["within_tested_range"]]


def detection(stats: dict) -> Figure | None:
    rows = detection_rows(stats)
    if not rows:
        return None
    fig = Figure(figsize=SIZE, layout="constrained")
    raw, rel = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    band = stats["literature"]["detection"]
    rel.fill_between(band["frequency_hz"], band["low_db"], band["high_db"], **BAND,
                     label="literature (Verrillo 1963; Gescheider et al. 2002)")
    models = sorted({r[0] for r in rows})
    for i, model in enumerate(models):
        mine = sorted((r[2] for r in rows if r[0] == model), key=lambda m: m["carrier_hz"])
        colour = COLOURS[i % len(COLOURS)]
        x = [m["carrier_hz"] for m in mine]
        y = np.array([m["value"] for m in mine], float)
        raw.plot(x, y, color=colour, lw=1)
        for j, m in enumerate(mine):
            _errorbar(raw, m["carrier_hz"], m, colour, model if j == 0 else None)
        ref = y[y > 0].min() if np.any(y > 0) else np.nan
        rel.plot(x, 20 * np.log10(y / ref), "o-", color=colour, label=model)
    raw.set(xscale="log", yscale="log", xlabel="carrier (Hz)", ylabel="threshold (% of the drive)",
            title="Detection threshold (device units, 95 % CI)")
    rel.set(xscale="log", xlabel="carrier (Hz)", ylabel="dB re the device's lowest threshold",
            title="Shape against the literature")
    raw.legend(fontsize=8)
    rel.legend(fontsize=8)
    return fig


def discrimination(stats: dict) -> Figure | None:
    found = _measures(stats, DISCRIMINATION)
    keys = [k for k in DISCRIMINATION if k in found]
    if not keys:
        return None
    panels = [(k, part) for k in keys for part in sorted({r[1] for r in found[k]})]
    cols = min(len(panels), 3)
    fig = Figure(figsize=(SIZE[0], 3.2 * -(-len(panels) // cols)), layout="constrained")
    models = sorted({c["model"] for c in stats["devices"]})
    for i, (key, part) in enumerate(panels):
        ax = fig.add_subplot(-(-len(panels) // cols), cols, i + 1)
        band = stats["literature"]["bands"].get(key)
        if band:
            ax.axhspan(band["low"], band["high"], **BAND, label="literature")
        for model, p, m in found[key]:
            if p == part and m.get("within_tested_range", True):
                _errorbar(ax, models.index(model), m, COLOURS[models.index(model) % len(COLOURS)])
        unit = next(m["unit"] for _, p, m in found[key] if p == part)
        ax.set_xticks(range(len(models)), models, rotation=30, ha="right")  # model names would overlap
        ax.set(xlim=(-0.6, len(models) - 0.4), ylabel=unit or "fraction")
        ax.set_title(f"{part}: {found[key][0][2]['label']}", fontsize=9)
        if band:
            ax.legend(fontsize=7)
    return fig


def information(stats: dict) -> Figure | None:
    rows = _measures(stats, ("it_bits",)).get("it_bits", [])
    if not rows:
        return None
    fig = Figure(figsize=(5.0, 3.5), layout="constrained")
    ax = fig.add_subplot()
    for i, (_, _, m) in enumerate(rows):
        _errorbar(ax, i, m, COLOURS[i % len(COLOURS)])
        ax.hlines(m["maximum"], i - 0.3, i + 0.3, color="grey", ls="--", lw=1,
                  label="log2 of the stimuli" if i == 0 else None)
    ax.set_xticks(range(len(rows)), [r[0] for r in rows])
    ax.set(xlim=(-0.6, len(rows) - 0.4), ylim=(0, None), ylabel="bits (Miller–Madow corrected)",
           title="Contact-angle identification")
    ax.legend(fontsize=8, loc="lower right")
    return fig


def positioning(stats: dict) -> Figure | None:
    found = _measures(stats, ("trajectory_length", "completion_time"))
    if not found:
        return None
    fig = Figure(figsize=SIZE, layout="constrained")
    for i, key in enumerate(("trajectory_length", "completion_time")):
        ax = fig.add_subplot(1, 2, i + 1)
        rows = found.get(key, [])
        for j, (_, _, m) in enumerate(rows):
            _errorbar(ax, j, m, COLOURS[j % len(COLOURS)])
        ax.set_xticks(range(len(rows)), [r[0] for r in rows])
        ax.set(xlim=(-0.6, max(len(rows), 1) - 0.4), title=rows[0][2]["label"] if rows else key,
               ylabel=rows[0][2]["unit"] if rows else "")
    fig.suptitle("Positioning with the device's guidance (95 % CI)")
    return fig


FIGURES = (
    ("detection", "Detection threshold against carrier frequency, devices overlaid", detection,
     literature.DETECTION_SOURCES),
    ("discrimination", "Discrimination: JNDs and Weber fractions per device", discrimination,
     tuple(s for b in literature.BANDS.values() for s in b.sources)),
    ("information", "Information transfer per device", information, ()),
    ("positioning", "Positioning: path length and completion time per device", positioning, ()),
)


def all_figures(stats: dict) -> list[dict]:
    """Every figure the data allow: {name, title, svg, sources}."""
    out = []
    for name, title, make, sources in FIGURES:
        fig = make(stats)
        if fig is not None:
            out.append({"name": name, "title": title, "svg": svg(fig), "sources": list(dict.fromkeys(sources))})
    return out
