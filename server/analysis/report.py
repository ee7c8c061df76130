"""report.html: one self-contained page (inline CSS, figures embedded as base64 SVG, no scripts,
nothing fetched) built from stats.json's content and the figure files.
"""

from __future__ import annotations

import base64
import re
from html import escape

from server.analysis.psychophysics import slug
from server.analysis.stats import anova_text, p_text

CSS = """
body { font: 15px/1.45 system-ui, sans-serif; margin: 0 auto; max-width: 1100px; padding: 1em 2em; color: #222; }
h1 { font-size: 1.6em; } h2 { border-bottom: 2px solid #ddd; margin-top: 2em; } h3 { margin-top: 1.5em; }
table { border-collapse: collapse; margin: .6em 0 1em; font-size: 13px; }
th, td { border: 1px solid #ccc; padding: 3px 8px; text-align: right; }
th { background: #f3f3f3; text-align: left; } td.t, td:first-child { text-align: left; }
figure { margin: 1em 0; } figure img { max-width: 100%; height: auto; border: 1px solid #eee; }
figcaption { font-size: 13px; color: #555; }
.skip { color: #8a5a00; background: #fff6e0; padding: 4px 8px; border-left: 3px solid #e0a800; }
.note { color: #444; font-size: 13px; } code { background: #f4f4f4; padding: 0 3px; }
"""


def fmt(value, digits: int = 2) -> str:
    """A number for people: two decimals, three below 1 (We = 0.056)."""
    if value is None:
        return "—"
    if isinstance(value, float):
        return f"{value:.3f}" if 0 < abs(value) < 1 and digits == 2 else f"{value:.{digits}f}"
    return escape(str(value))


def key(value) -> str:
    """A condition's value as a label: −90, 2, 166.67 (no trailing zeros)."""
    if value is None:
        return "—"
    return f"{value:g}" if isinstance(value, float) else escape(str(value))


NUMERIC = re.compile(r"^(p [<=] \.?\d.*|[−-]?[\d.]+%?|\[.*\]|—)$")  # numbers, p values, intervals


def table(headers: list[str], rows: list[list]) -> str:
    """Numbers (and p values, intervals) right-aligned, text left-aligned."""
    def cell(c) -> str:
        text = c if isinstance(c, str) else fmt(c)
        return f"<td>{text}</td>" if not isinstance(c, str) or NUMERIC.match(c) else f'<td class="t">{text}</td>'

    head = "".join(f"<th>{escape(h)}</th>" for h in headers)
    body = "".join("<tr>" + "".join(cell(c) for c in row) + "</tr>" for row in rows)
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def ci(d: dict | None) -> str:
    if not d or d.get("ci95_low") is None:
        return "—"
    return f"[{d['ci95_low']:.2f}, {d['ci95_high']:.2f}]"


def desc_cells(d: dict | None) -> list:
    d = d or {}
    return [d.get("n_participants"), d.get("n_trials"), d.get("mean"), d.get("sd"), ci(d)]


DESC = ["participants", "trials", "mean", "SD", "95 % CI"]


class Page:
    def __init__(self, stats: dict, figures: list[dict]):
        self.stats, self.figures, self.parts = stats, figures, []

    def add(self, html: str) -> None:
        self.parts.append(html)

    def p(self, text: str, cls: str = "") -> None:
        self.add(f'<p class="{cls}">{text}</p>' if cls else f"<p>{text}</p>")

    def skip(self, path: str) -> bool:
        """A skip note if `path` was skipped; True when it was."""
        reason = self.stats["skipped"].get(path)
        if reason:
            self.p(f"Skipped <code>{escape(path)}</code>: {escape(reason)}", "skip")
        return bool(reason)

    def figure(self, name: str) -> None:
        for f in self.figures:
            if f["name"] == name:
                svg = base64.b64encode(f["svg"].read_bytes()).decode("ascii")
                self.add(f'<figure id="fig-{escape(name)}"><img alt="{escape(f["title"])}" '
                         f'src="data:image/svg+xml;base64,{svg}"><figcaption>{escape(f["title"])} '
                         f'(figures/{escape(name)}.png, .svg)</figcaption></figure>')


def render(stats: dict, figures: list[dict]) -> str:
    page = Page(stats, figures)
    prov = stats["provenance"]
    page.add(f"<h1>ViESTac analysis: {escape(prov['study_title'])}</h1>")
    _provenance(page, prov)
    _task1(page, stats["task1"])
    _task2(page, stats["task2"])
    _task3(page, stats["task3"])
    _task4(page, stats["task4"])
    _psychophysics(page, stats["psychophysics"])
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>ViESTac analysis: {escape(prov['study_id'])}</title><style>{CSS}</style></head>"
            f"<body>{''.join(page.parts)}</body></html>\n")


def _provenance(page: Page, prov: dict) -> None:
    page.add("<h2>Data and methods</h2>")
    a = prov["analysis"]
    page.p(f"Study <code>{escape(prov['study_id'])}</code>, {prov['n_sessions']} sessions, "
           f"{prov['n_participants']} participants, database <code>{escape(prov['database'])}</code>. "
           f"Study file SHA-256: {', '.join(f'<code>{h[:16]}…</code>' for h in prov['study_hashes'])}. "
           f"Recorded by ViESTac {escape(', '.join(prov['software_versions']))}; analysed by ViESTac "
           f"{escape(a['viestac'])} with " + ", ".join(f"{k} {escape(v)}" for k, v in a.items() if k != "viestac")
           + ".")
    for w in prov["warnings"]:
        page.p(f"Warning: {escape(w)}", "skip")
    page.add(table(["session", "participant", "index", "device", "status", "trials", "answered", "excluded",
                    "version"], [[s["session"], s["participant"], s["participant_index"], s["device"], s["status"],
                                  s["trials"], s["answered"], s["excluded"], s["software_version"]]
                                 for s in prov["sessions"]]))
    page.p("Trials per status: " + ", ".join(f"{k} {v}" for k, v in prov["trial_status"].items())
           + ". Only answered trials are analysed.")
    if prov["excluded_trials"]:
        page.add("<h3>Excluded trials</h3>")
        page.add(table(["participant", "session", "seq", "task", "kind", "reason"],
                       [[t["participant"], t["session"], t["seq"], t["task"], t["kind"], t["reason"]]
                        for t in prov["excluded_trials"]]))
    page.add("<h3>Methods</h3><ul>" + "".join(f"<li><b>{escape(k)}</b>: {escape(v)}</li>"
                                               for k, v in page.stats["methods"].items()) + "</ul>")


def _task1(page: Page, t: dict) -> None:
    page.add("<h2>Task 1: contact angle discrimination</h2>")
    page.p(f"{t['n_trials']} trials of {t['n_participants']} participants; deviation = |answer − presented angle|.")
    if page.skip("task1.per_angle"):
        return
    page.figure("task1_angles")
    page.add(table(["angle (deg)", *DESC, "mean signed error"],
                   [[key(r["angle"]), *desc_cells(r), r["mean_signed_error"]] for r in t["per_angle"]]))
    page.p(f"Overall mean absolute deviation {fmt(t['mean_abs_dev']['mean'])}° (95 % CI {ci(t['mean_abs_dev'])}).")
    if not page.skip("task1.rm_anova"):
        r = t["rm_anova"]
        page.p(f"Repeated-measures ANOVA over angles ({r['n_participants']} participants): {anova_text(r)}; "
               f"uncorrected {p_text(r['p_unc'])}, η²G = {fmt(r['ng2'], 3)}.")
    if not page.skip("task1.quadratic_trend"):
        q = t["quadratic_trend"]
        page.p(f"Quadratic trend (OLS, n = {q['n']}): deviation = {q['b0']:.3g} + {q['b1']:.3g}·angle + "
               f"{q['b2']:.3g}·angle²; quadratic term F({q['df_quadratic'][0]:g}, {q['df_quadratic'][1]:g}) = "
               f"{fmt(q['F_quadratic'])}, {p_text(q['p_quadratic'])}; R² = {fmt(q['r2'], 3)}.")


def _task2(page: Page, t: dict) -> None:
    page.add("<h2>Task 2: texture discrimination</h2><h3>A: second vs first (7-point rating)</h3>")
    pairs = t["pairs"]
    page.p(f"{pairs['n_trials']} trials of {pairs['n_participants']} participants.")
    if not page.skip("task2.pairs.per_comparison"):
        page.figure("task2_ratings")
        page.add(table(["comparison", *DESC], [[r["comparison"], *desc_cells(r)] for r in pairs["per_comparison"]]))
        if not page.skip("task2.pairs.rm_anova"):
            page.p(f"Repeated-measures ANOVA over comparisons ({pairs['rm_anova']['n_participants']} participants): "
                   f"{anova_text(pairs['rm_anova'])}.")
        if not page.skip("task2.pairs.posthoc"):
            ph = pairs["posthoc"]
            page.p(f"Post-hoc paired t-tests against <b>{escape(pairs['reference'])}</b>, Bonferroni over all "
                   f"{ph['n_pairs_corrected']} pairs:")
            page.add(table(["comparison", "mean difference", "T", "df", "p (uncorrected)", "p (Bonferroni)",
                            "Hedges g"], [[r["comparison"], r["mean_diff"], r["T"], key(r["dof"]),
                                           p_text(r["p_unc"]), p_text(r["p_bonf"]), r["hedges_g"]]
                                          for r in ph["tests"]]))
    page.add("<h3>B: identification</h3>")
    ident = t["identification"]
    page.p(f"{ident['n_trials']} trials of {ident['n_participants']} participants.")
    if not page.skip("task2.identification.crosstab"):
        ct = ident["crosstab"]
        page.figure("task2_crosstab")
        page.add(table(["actual \\ detected (Hz)", *[f"{v:g}" for v in ct["detected_hz"]], "hit rate"],
                       [[f"{a:g}", *row, f"{h['rate']:.0%}"] for a, row, h in
                        zip(ct["actual_hz"], ct["counts"], ct["hit_rate"])]))
        page.p(f"Overall accuracy {ct['accuracy']:.0%}.")
    if not page.skip("task2.kendall_tau"):
        page.p(f"Kendall's τ<sub>b</sub> (actual vs detected, n = {t['kendall_tau_n']} trials): "
               f"τ = {fmt(t['kendall_tau'], 3)}, {p_text(t['kendall_tau_p'])}.")


def _task3(page: Page, t: dict) -> None:
    page.add("<h2>Task 3: stiffness magnitude estimation and production</h2>")
    page.p(f"Power law p = a·S<sup>b</sup> fitted by {escape(t['fit_method'])}, on levels "
           f"{t['fit_levels'][0]}..{t['fit_levels'][-1]} only (levels 1 and 10 are the references).", "note")
    for mode in ("estimation", "production"):
        part = t[mode]
        page.add(f"<h3>Magnitude {mode}</h3>")
        page.p(f"{part['n_trials']} trials of {part['n_participants']} participants.")
        if page.skip(f"task3.{mode}.per_level"):
            continue
        page.figure(f"task3_{mode}")
        extra = ["mean match time (s)"] if mode == "production" else []
        page.add(table(["level", *DESC, *extra], [[key(r["level"]), *desc_cells(r),
                                                    *([r.get("match_time_s_mean")] if extra else [])]
                                                   for r in part["per_level"]]))
        if not page.skip(f"task3.{mode}.fit"):
            f = part["fit"]
            nls = f["nls"]
            page.p(f"p = {f['a']:.3f}·S<sup>{f['b']:.3f}</sup> (b 95 % CI [{f['b_ci95'][0]:.3f}, "
                   f"{f['b_ci95'][1]:.3f}], R² in log space {f['r2_log']:.3f}, n = {f['n']} trials)."
                   + (f" Non-linear least squares for comparison: a = {nls['a']:.3f}, b = {nls['b']:.3f}."
                      if nls else ""))


def _measure_rows(rows: list[dict], keys: list[str]) -> list[list]:
    out = []
    for r in rows:
        for m in ("trajectory_length", "completion_time", "helpfulness"):
            out.append([*(r[k] for k in keys), m.replace("_", " "), *desc_cells(r[m])])
    return out


def _task4(page: Page, t: dict) -> None:
    page.add("<h2>Task 4: object positioning</h2>")
    page.p(f"{t['n_trials']} trials of {t['n_participants']} participants. A device's means are over its guidance "
           f"trials (cues {', '.join(t['guidance_cues'])}).")
    o = t["outliers"]
    page.p(f"Outlier rule: {escape(o['rule'])}. Excluded: {o['n_excluded']} trial(s).", "note")
    if o["trials"]:
        page.add(table(["participant", "device", "cue", "object", "measure", "value", "median", "bounds"],
                       [[r["participant"], r["device"], r["cue"], r["object"], r["measure"], r["value"], r["median"],
                         f"[{r['low']:.2f}, {r['high']:.2f}]"] for r in o["trials"]]))
    for device, part in t.items():
        if not (isinstance(part, dict) and "by_cue_object" in part) and device not in ("fingertac", "ferrovibe"):
            continue
        page.add(f"<h3>{escape(device)}</h3>")
        if page.skip(f"task4.{device}"):
            continue
        page.figure(f"task4_{device}")
        page.add(table(["all guidance trials", "measure", *DESC], _measure_rows([{"x": "all", **part}], ["x"])))
        page.add(table(["cue", "measure", *DESC], _measure_rows(part["by_cue"], ["cue"])))
        page.add(table(["target", "measure", *DESC], _measure_rows(part["by_object"], ["object"])))
        for m, r in part["rm_anova"].items():
            if page.skip(f"task4.{device}.rm_anova.{m}"):
                continue
            text = "; ".join(f"{e['source']}: {anova_text(e)}" for e in r["effects"])
            page.p(f"rm-ANOVA of {m.replace('_', ' ')} over {' × '.join(r['within'])} "
                   f"({r['n_participants']} participants): {text}.")
    page.figure("task4_helpfulness")
    page.add("<h3>Device comparison</h3>")
    page.figure("task4_devices")
    if not page.skip("task4.comparison"):
        for name, c in t["comparison"].items():
            if page.skip(f"task4.comparison.{name}"):
                continue
            a, b = c["devices"]
            page.add(table(["measure", "pairs", f"mean {a}", f"mean {b}", "difference", "T", "df", "p (t-test)",
                            "Cohen d", "Wilcoxon W", "p (Wilcoxon)"],
                           [[m.replace("_", " "), r["n_pairs"], r[f"mean_{a}"], r[f"mean_{b}"], r["mean_diff"], r["T"],
                             key(r["dof"]), p_text(r["p"]), r["cohen_d"], r["wilcoxon_W"], p_text(r["wilcoxon_p"])]
                            for m in ("trajectory_length", "completion_time", "helpfulness") if (r := c[m])]))
            page.p(f"Caution: {escape(c['note'])}; the difference mixes device and learning.", "note")
    page.add("<h3>Speed-accuracy</h3>")
    page.figure("task4_speed_accuracy")
    for device, sa in t["speed_accuracy"].items():
        if not page.skip(f"task4.speed_accuracy.{device}") and sa:
            bits = [f"{label} ρ = {r['rho']:.2f} ({p_text(r['p'])}, n = {r['n']})"
                    for label, r in (("time vs length", sa["time_vs_length"]),
                                     ("time vs end-point error", sa["time_vs_end_error"])) if r]
            page.p(f"{escape(device)}: Spearman " + "; ".join(bits) + ".")
    page.add("<h3>Throughput (ISO 9241-411)</h3>")
    if not page.skip("task4.throughput"):
        tp = t["throughput"]
        page.p(escape(tp["method"]) + ". The GO rule holds the object inside the target tolerance on every axis, "
               "so end points are truncated by design: the throughput compares cues and devices of this task, not "
               "pointing throughputs elsewhere.", "note")
        page.add(table(["device", "cue", "object", "n", "D", "Ae", "We", "IDe (bits)", "MT (s)", "TP (bits/s)"],
                       [[c["device"], c["cue"], c["object"], c["n"], c["D"], c["Ae"], c["We"], c["IDe"], c["MT"],
                         c["TP"]] for c in tp["conditions"]]))
        page.p("Mean throughput per device: " + ", ".join(f"{escape(d)} {v:.2f} bits/s"
                                                           for d, v in tp["by_device"].items()) + ".")
    page.add("<h3>Questionnaires</h3>")
    if not page.skip("task4.questionnaire"):
        for q, r in t["questionnaire"].items():
            if r["kind"] == "choice":
                page.add(f"<p><code>{escape(q)}</code> ({escape(', '.join(r['tasks']))}), n = {r['n']}:</p>")
                page.add(table(["answer", "n", "share"], [[c["value"], c["n"], f"{c['share']:.1%}"]
                                                          for c in r["counts"]]))
            else:
                page.p(f"<code>{escape(q)}</code>: mean {fmt(r['mean'])} (SD {fmt(r['sd'])}, 95 % CI {ci(r)}, "
                       f"n = {r['n_trials']}).")


def interval(pair: list | None) -> str:
    """A [low, high] pair as the report shows it."""
    if not pair or pair[0] is None or pair[1] is None:
        return "—"
    return f"[{fmt(pair[0])}, {fmt(pair[1])}]"


def _who(cell: dict) -> str:
    return "pooled" if cell["participant"] is None else cell["participant"]


def _psychophysics(page: Page, psy: dict) -> None:
    if not psy["tasks"]:
        return
    page.add("<h2>Psychophysics</h2>")
    page.p(f"{psy['n_trials']} trials of {psy['n_participants']} participants in {psy['n_tasks']} task(s). "
           f"{escape(page.stats['methods']['psychophysics'])}.", "note")
    for path, reason in page.stats["skipped"].items():
        if path.startswith("psychophysics.") and path.endswith(".unusable"):
            page.p(f"Skipped <code>{escape(path)}</code>: {escape(reason)}", "skip")
    for task in psy["tasks"]:
        name = f"psy_{escape(task['task'])}"
        page.add(f"<h3 id=\"{name}\">{escape(task['task'])}: {escape(task['design'])}, "
                 f"{escape(str(task['parameter']))} ({escape(str(task['unit'] or ''))})</h3>")
        page.p(f"{task['n_trials']} trials of {task['n_participants']} participants; guess rate "
               f"{fmt(task['guess'])}; answers {escape(', '.join(task['choices']))}.")
        for f in page.figures:
            if f["section"] == "psychophysics" and f["name"].startswith(f"psy_{slug(task['task'])}_"):
                page.figure(f["name"])
        cells = [(c, cell) for c in task["conditions"] for cell in [c["pooled"], *c["participants"]]]
        if task["design"] != "identification":
            page.add(table(["condition", "participant", "trials", "family", "threshold", "95 % CI", "slope",
                            "95 % CI", "lapse", "midpoint (F = ½)", "95 % CI", "deviance", "p (bootstrap)",
                            "procedure's estimate"],
                           [[c["condition"], _who(cell), cell["n_trials"], *_fit_cells(cell),
                             cell["procedure_estimate"]] for c, cell in cells]))
        if task["design"] in ("yes-no", "same-different"):
            page.add(table(["condition", "participant", "model", "hits", "signal trials", "false alarms",
                            "noise trials", "d′", "criterion"],
                           [[c["condition"], _who(cell), *_sdt_cells(cell["sdt"])] for c, cell in cells]))
        if task["design"] == "identification":
            page.add(table(["condition", "participant", "trials", "accuracy", "IT (bits)", "IT corrected (bits)",
                            "log2 k"], [[c["condition"], _who(cell), *_it_cells(cell)] for c, cell in cells]))
        for c, cell in cells:
            for part in ("fit", "bootstrap", "sdt", "information"):
                page.skip(f"psychophysics.{task['task']}.{c['condition']}.{_who(cell)}.{part}")


def _fit_cells(cell: dict) -> list:
    f, b = cell["fit"], cell["bootstrap"] or {}
    if not f:
        return ["—"] * 10
    return [f["family"], f["threshold"], interval(b.get("threshold_ci95")), f["slope"],
            interval(b.get("slope_ci95")), f["lapse"], f["midpoint"], interval(b.get("midpoint_ci95")),
            f["deviance"], b.get("deviance_p")]


def _sdt_cells(s: dict | None) -> list:
    if not s:
        return ["—"] * 7
    return [s["model"], s["hits"], s["signal_trials"], s["false_alarms"], s["noise_trials"], s["d_prime"],
            s["criterion"]]


def _it_cells(cell: dict) -> list:
    i = cell["information"]
    if not i:
        return [cell["n_trials"], "—", "—", "—", "—"]
    return [i["trials"], i["accuracy"], i["bits"], i["corrected"], i["maximum"]]
