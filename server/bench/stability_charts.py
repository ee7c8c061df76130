"""The charts of `viestac bench stability`, drawn from the sections of stability.json with
matplotlib's object API (no pyplot); saved by server.analysis.figures.save (PNG + SVG,
deterministic)."""

from __future__ import annotations

from math import ceil

import numpy as np
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import FixedLocator, NullLocator, ScalarFormatter

from server.analysis.figures import COLOURS

GREEN, ORANGE, RED = "#2ca02c", "#ff7f0e", "#d62728"


def _title(family: str, label: str) -> str:
    return family if label == family else f"{family}: {label}"


def popthrough(section: dict) -> Figure:
    """One heat map per method: fraction of runs failing per speed x thickness cell, with the
    most common failure kind written in failing cells."""
    p = section["parameters"]
    speeds, thick = p["speeds_m_s"], p["thicknesses_m"]
    methods, letters = section["methods"], p["kind_letters"]
    ncols = min(len(methods), 3)
    nrows = ceil(len(methods) / ncols)
    fig = Figure(figsize=(3.4 * ncols + 1.4, 3.0 * nrows + 1.1), layout="constrained")
    image = None
    for i, m in enumerate(methods):
        ax = fig.add_subplot(nrows, ncols, i + 1)
        cells = {(c["speed_m_s"], c["thickness_m"]): c for c in section["cells"]
                 if (c["family"], c["label"]) == (m["family"], m["label"])}
        grid = np.array([[cells[(s, t)]["fraction"] for s in speeds] for t in thick])
        image = ax.imshow(grid, origin="lower", cmap="RdYlGn_r", vmin=0.0, vmax=1.0, aspect="auto")
        for (r, col), value in np.ndenumerate(grid):
            cell = cells[(speeds[col], thick[r])]
            text = letters.get(cell["kind"], "?") if cell["kind"] else ("s" if cell["proxy_sank"] else "")
            dark = value < 0.2 or value > 0.7  # the ends of RdYlGn are dark, its middle is pale
            ax.text(col, r, text, ha="center", va="center", fontsize=8, color="white" if dark else "black")
        ax.set_xticks(range(len(speeds)), [f"{s:g}" for s in speeds], fontsize=8)
        ax.set_yticks(range(len(thick)), [f"{t * 1000:g}" for t in thick], fontsize=8)
        ax.set(xlabel="HIP speed (m/s, log-spaced)", ylabel="plate thickness (mm, log-spaced)",
               title=f"{_title(m['family'], m['label'])}: {m['failing_cells']}/{m['cells']} cells fail")
    fig.colorbar(image, ax=fig.axes, label="fraction of runs failing", shrink=0.6)
    legend = ", ".join(f"{letter} = {kind}" for kind, letter in letters.items())
    fig.suptitle(f"Pop-through map: point proxy driven straight down through a plate at {p['tick_hz']} Hz\n"
                 f"({p['runs_per_cell']} runs per cell; most common failure: {legend};\n"
                 f"s = passes, but the proxy sat over {p['sank_fraction']:g} of the plate below its top face)",
                 fontsize="medium")
    return fig


def _log_edges(values: list[float]) -> np.ndarray:
    """Cell edges (geometric midpoints) around log-spaced centres."""
    v = np.log(np.asarray(values, dtype=float))
    mid = (v[1:] + v[:-1]) / 2
    return np.exp(np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]]))


def _wall_class(cell: dict) -> int:
    """0 stable, 1 growing ripple without losing contact, 2 bouncing."""
    if not cell["oscillating"]:
        return 0
    return 2 if cell["bounces"] else 1


def stiffness(section: dict) -> Figure:
    """Stable / oscillating map over servo rate x stiffness with the passivity bound 2b/T, the
    measured boundary per rate and the server's default marked."""
    p = section["parameters"]
    rates, ks = p["rates_hz"], p["stiffnesses_n_per_m"]
    cells = {(c["rate_hz"], c["stiffness_n_per_m"]): c for c in section["cells"]}
    grid = np.array([[_wall_class(cells[(f, k)]) for f in rates] for k in ks])
    fig = Figure(figsize=(7.0, 5.0), layout="constrained")
    ax = fig.add_subplot()
    ax.pcolormesh(_log_edges(rates), _log_edges(ks), grid, cmap=ListedColormap([GREEN, ORANGE, RED]),
                  vmin=-0.5, vmax=2.5, alpha=0.55, edgecolors="white", linewidth=0.5)
    f = np.geomspace(_log_edges(rates)[0], _log_edges(rates)[-1], 50)
    ax.plot(f, 2 * p["damping_n_s_per_m"] * f, color="black", lw=2, label="passivity bound K = 2b/T")
    bounds = [b for b in section["boundary_by_rate"] if b["largest_stable_n_per_m"] is not None]
    ax.plot([b["rate_hz"] for b in bounds], [b["largest_stable_n_per_m"] for b in bounds], "o", color=COLOURS[0],
            ms=7, label="largest stable K found (bisection)")
    for b in bounds:
        ax.annotate(f"{b['largest_stable_n_per_m']:.0f}", (b["rate_hz"], b["largest_stable_n_per_m"]),
                    textcoords="offset points", xytext=(6, -12), fontsize="small", color=COLOURS[0])
    d = section["default"]
    ax.plot([d["rate_hz"]], [d["stiffness_n_per_m"]], "*", color="gold", mec="black", ms=16,
            label=f"default: {d['stiffness_n_per_m']:g} N/m at {d['rate_hz']:g} Hz")
    ax.set(xscale="log", yscale="log", xlabel="servo rate f = 1/T (Hz)", ylabel="wall stiffness K (N/m)",
           title=f"Virtual wall on a modelled 1-DoF device (m = {p['mass_kg']:g} kg, b = "
                 f"{p['damping_n_s_per_m']:g} N·s/m, push {p['push_n']:g} N)")
    ax.xaxis.set_major_locator(FixedLocator(rates))
    ax.xaxis.set_major_formatter(ScalarFormatter())
    ax.xaxis.set_minor_locator(NullLocator())
    handles, _ = ax.get_legend_handles_labels()
    classes = ((GREEN, "stable"), (ORANGE, "oscillating, ripple growing"), (RED, "oscillating, bouncing off the wall"))
    handles += [Patch(color=c, alpha=0.55, label=t) for i, (c, t) in enumerate(classes) if i in grid]
    ax.legend(handles=handles, loc="upper left", fontsize="small")
    return fig


def chatter(section: dict) -> Figure:
    """Chatter rate against the hysteresis band per tracker noise sigma (symlog y), with the raw
    (ungated) rate at the left, the stability threshold and the default marked."""
    p = section["parameters"]
    bands = p["bands_m"]
    x_raw, xs = 0, np.arange(1, len(bands) + 1)
    fig = Figure(figsize=(9.0, 4.5), layout="constrained")
    ax = fig.add_subplot()
    for i, sigma in enumerate(p["sigmas_m"]):
        colour = COLOURS[i % len(COLOURS)]
        rows = {c["band_m"]: c["chatter_per_s"] for c in section["cells"]
                if c["sigma_m"] == sigma and c["gate"] == "hysteresis"}
        raw = next(c["chatter_per_s"] for c in section["cells"] if c["sigma_m"] == sigma and c["gate"] == "raw")
        ax.plot(xs, [rows[b] for b in bands], "o-", color=colour, label=f"σ = {sigma * 1000:g} mm")
        # the raw rates of different sigmas nearly coincide: spread them so each stays visible
        ax.plot([x_raw + 0.08 * (i - (len(p["sigmas_m"]) - 1) / 2)], [raw], "s", color=colour, mfc="none", ms=7)
    ax.axhline(p["stable_threshold_per_s"], color="grey", ls="--", lw=1,
               label=f"stable: ≤ {p['stable_threshold_per_s']:g} transitions/s")
    ax.axvline(x_raw + 0.5, color="grey", lw=0.8)
    band, leap = p["default_band_m"], p["leap_sigma_m"]
    cell = next(c for c in section["cells"] if c["sigma_m"] == leap and c["gate"] == "hysteresis"
                and c["band_m"] == band)
    ax.plot([xs[bands.index(band)]], [cell["chatter_per_s"]], "*", color="gold", mec="black", ms=16, zorder=5,
            label=f"default: band {band * 1000:g} mm at σ {leap * 1000:g} mm (Leap)")
    ax.set_yscale("symlog", linthresh=0.1)
    ax.set_ylim(bottom=0)
    ax.set_xticks([x_raw, *xs], ["raw\n(no gate)", *[f"{b * 1000:g}" for b in bands]])
    ax.set(xlabel=f"hysteresis band (mm), dwell {p['dwell_s'] * 1000:g} ms on and off",
           ylabel="contact transitions per second (symlog)",
           title=f"Contact chatter resting on the dome top\n({p['tracker_hz']} Hz tracker, noise held over "
                 f"{p['tick_hz']} Hz ticks, {p['duration_s']:g} s per cell)")
    handles, _ = ax.get_legend_handles_labels()
    handles.append(Line2D([], [], ls="none", marker="s", mfc="none", color="grey",
                          label="raw: band 0, dwell 0 (one square per σ)"))
    fig.legend(handles=handles, loc="outside right upper", fontsize="small")
    return fig
