"""report-card.html: one self-contained page (inline CSS, figures as SVG data URIs, no scripts,
nothing fetched) from stats.json's content and the drawn figures. Every number printed from
stats.json carries its path there (`data-stat`) and its exact value (`data-value`), so a test can
check the page against the file."""

from __future__ import annotations

import base64
import json
from html import escape

from server.analysis.report import CSS, fmt

EXTRA_CSS = """
.status-skipped td { color: #8a5a00; } .status-nodata td { color: #777; }
.beyond { color: #a00; font-size: 12px; } .sources { font-size: 12px; color: #444; } .sources li { margin: .2em 0; }
"""


def stat(path: str, value, text: str | None = None) -> str:
    """A number with its stats.json path and exact value."""
    shown = fmt(value) if text is None else text
    return (f'<span data-stat="{escape(path)}" data-value="{escape(json.dumps(value))}">{shown}</span>')


def interval(path: str, pair) -> str:
    if not pair:
        return "—"
    return f"[{stat(path + '.0', pair[0])}, {stat(path + '.1', pair[1])}]"


def _figure(f: dict, sources: dict) -> str:
    data = base64.b64encode(f["svg"].encode("utf-8")).decode("ascii")
    cites = "".join(f"<li>{escape(sources[s])}</li>" for s in f["sources"])
    cited = f'<ul class="sources">Reference bands: {cites}</ul>' if cites else ""
    return (f'<figure id="fig-{escape(f["name"])}"><img alt="{escape(f["title"])}" '
            f'src="data:image/svg+xml;base64,{data}"><figcaption>{escape(f["title"])}</figcaption>{cited}</figure>')


def _measure_cell(path: str, m: dict) -> list[str]:
    physical = m.get("physical")
    phys = "—"
    if physical and physical.get("value") is not None:
        phys = (f"{stat(path + '.physical.value', physical['value'])} {escape(physical['unit'])} "
                f"{interval(path + '.physical.ci95', physical.get('ci95'))}")
    elif physical:
        phys = escape(physical["reason"] or "—")
    flag = ("" if m.get("within_tested_range", True) else
            ' <span class="beyond" title="the fitted threshold lies beyond every level tested: an '
            'extrapolation, left out of the figures">(beyond the tested levels)</span>')
    return [escape(m["label"]), escape(m["condition"]), stat(path + ".value", m["value"]) + flag,
            interval(path + ".ci95", m["ci95"]), escape(m["unit"] or "—"),
            stat(path + ".n_participants", m["n_participants"]), stat(path + ".n_trials", m["n_trials"]), phys]


def _rows(headers: list[str], rows: list[tuple[str, list[str]]]) -> str:
    head = "".join(f"<th>{escape(h)}</th>" for h in headers)
    body = "".join(f'<tr class="{cls}">' + "".join(f"<td>{c}</td>" for c in cells) + "</tr>" for cls, cells in rows)
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _device(i: int, c: dict) -> str:
    out = [f'<section id="device-{escape(c["model"])}"><h2>Device {escape(c["model"])}</h2>',
           f"<p>{stat(f'devices.{i}.n_participants', c['n_participants'])} participant(s)."
           + (f" Physical units from the audio calibration ({escape(c['calibration']['unit'])})."
              if c["calibration"] else " No calibration: device units only.") + "</p>"]
    rows = []
    for j, p in enumerate(c["parts"]):
        status = p["status"]
        if status != "measured":
            rows.append((f"status-{status.replace(' ', '')}",
                         [escape(p["title"]), f'<span class="part-status">{escape(status)}</span>',
                          f'<span class="part-reason">{escape(p["reason"] or "")}</span>', *[""] * 7]))
            continue
        for k, m in enumerate(p["measures"]):
            lead = [escape(p["title"]), '<span class="part-status">measured</span>'] if k == 0 else ["", ""]
            rows.append(("status-measured", lead + _measure_cell(f"devices.{i}.parts.{j}.measures.{k}", m)))
    out.append(_rows(["part", "status", "measure / reason", "condition", "value", "95 % CI", "unit",
                      "participants", "trials", "physical"], rows))
    if c["extra_tasks"]:
        out.append(f"<p>Tasks beyond the catalogue (see viestac analyze): {escape(', '.join(c['extra_tasks']))}</p>")
    return "".join(out) + "</section>"


def _comparison(side: dict) -> str:
    devices = sorted({d for r in side["table"] for d in r["devices"]})
    rows = []
    for i, r in enumerate(side["table"]):
        cells = [escape(r["part"]), escape(r["label"]), escape(r["condition"]), escape(r["unit"] or "—")]
        for d in devices:
            v = r["devices"].get(d)
            cells.append("—" if v is None else
                         f"{stat(f'comparison.table.{i}.devices.{d}.value', v['value'])} "
                         f"{interval(f'comparison.table.{i}.devices.{d}.ci95', v['ci95'])} "
                         f"(n = {stat(f'comparison.table.{i}.devices.{d}.n_participants', v['n_participants'])})")
        rows.append(("", cells))
    out = ['<section id="comparison"><h2>Side by side</h2>',
           _rows(["part", "measure", "condition", "unit", *devices], rows), "<h3>Paired tests</h3>"]
    if side["paired"]:
        prow = []
        for i, t in enumerate(side["paired"]):
            w, tt = t["wilcoxon"], t["t_test"]
            prow.append(("", [escape(t["part"]), escape(t["measure"]), escape(t["condition"]),
                              escape(" − ".join(t["devices"])), stat(f"comparison.paired.{i}.n_pairs", t["n_pairs"]),
                              stat(f"comparison.paired.{i}.median_difference", t["median_difference"]),
                              "—" if w is None else stat(f"comparison.paired.{i}.wilcoxon.p", w["p"]),
                              "—" if tt is None else stat(f"comparison.paired.{i}.t_test.p", tt["p"])]))
        out.append(_rows(["part", "measure", "condition", "devices", "pairs", "median difference",
                          "Wilcoxon p (verdict)", "paired t p"], prow))
    else:
        out.append("<p>No measure has enough participants who wore two devices.</p>")
    return "".join(out) + "</section>"


def render(stats: dict, figures: list[dict]) -> str:
    sources = stats["literature"]["sources"]
    body = ["<h1>ViESTac device report card</h1>",
            "<p>" + ", ".join(f"{escape(s['study_id'])} ({s['n_participants']} participants)"
                              for s in stats["provenance"]["studies"]) + "</p>"]
    body += [_device(i, c) for i, c in enumerate(stats["devices"])]
    body.append(_comparison(stats["comparison"]))
    body.append('<section id="figures"><h2>Figures</h2>' + "".join(_figure(f, sources) for f in figures)
                + "</section>")
    body.append("<h2>Methods</h2><ul>" + "".join(f"<li><b>{escape(k)}</b>: {escape(v)}</li>"
                                                 for k, v in stats["methods"].items()) + "</ul>")
    body.append('<h2>Literature</h2><ul class="sources">' + "".join(
        f'<li id="src-{escape(k)}">{escape(v)}</li>' for k, v in sources.items()) + "</ul>")
    if stats["skipped"]:
        body.append("<h2>Not computed</h2><ul>" + "".join(f"<li><code>{escape(k)}</code>: {escape(v)}</li>"
                                                         for k, v in stats["skipped"].items()) + "</ul>")
    return ("<!doctype html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>ViESTac device report card"
            f"</title><style>{CSS}{EXTRA_CSS}</style></head><body>{''.join(body)}</body></html>\n")
