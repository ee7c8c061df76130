"""Every hypothesis test of an analysis (stats.json) with its p-value, by a stable name.

The power analysis (`viestac study --power`, server/simulate/power.py) counts how often each of
these is significant over simulated studies. A name is the stats.json path of the test's object
plus what distinguishes the test inside it:

| name | p |
|---|---|
| `task1.rm_anova` | Greenhouse-Geisser p of the rm-ANOVA over angles |
| `task1.quadratic_trend` | the quadratic term's F test |
| `task2.pairs.rm_anova` | Greenhouse-Geisser p over the comparisons |
| `task2.pairs.posthoc.<comparison>` | Bonferroni p of the comparison against the reference |
| `task2.kendall_tau` | Kendall's tau-b, two-sided |
| `task3.<mode>.b` | the exponent's t test (b = 0) of the log-log OLS |
| `task4.<device>.rm_anova.<measure>.<effect>` | Greenhouse-Geisser p of each effect (cue, object, cue * object) |
| `task4.comparison.<a>_vs_<b>.<measure>` | paired t-test of the devices |
| `task4.comparison.<a>_vs_<b>.<measure>.wilcoxon` | Wilcoxon signed-rank test of the same pairs |
| `task4.speed_accuracy.<device>.<pair>` | Spearman's rho, two-sided |

A test whose analysis was skipped is absent; one that ran with an undefined p maps to None.
"""

from __future__ import annotations

from typing import Any


def p_values(stats: dict) -> dict[str, float | None]:
    """{test name: p} of every test present in `stats` (server.analysis.run.compute's first value)."""
    out: dict[str, float | None] = {}
    t1, t2, t3, t4 = (stats.get(k) or {} for k in ("task1", "task2", "task3", "task4"))
    if t1.get("rm_anova"):
        out["task1.rm_anova"] = t1["rm_anova"].get("p_gg")
    if t1.get("quadratic_trend"):
        out["task1.quadratic_trend"] = t1["quadratic_trend"].get("p_quadratic")
    pairs = t2.get("pairs") or {}
    if pairs.get("rm_anova"):
        out["task2.pairs.rm_anova"] = pairs["rm_anova"].get("p_gg")
    for test in (pairs.get("posthoc") or {}).get("tests") or []:
        out[f"task2.pairs.posthoc.{test['comparison']}"] = test.get("p_bonf")
    if t2.get("kendall_tau") is not None:
        out["task2.kendall_tau"] = t2.get("kendall_tau_p")
    for mode in ("estimation", "production"):
        fit = (t3.get(mode) or {}).get("fit")
        if fit:
            out[f"task3.{mode}.b"] = fit.get("p_b")
    for device, part in t4.items():
        if isinstance(part, dict) and isinstance(part.get("rm_anova"), dict):
            for measure, anova in part["rm_anova"].items():
                for effect in (anova or {}).get("effects") or []:
                    out[f"task4.{device}.rm_anova.{measure}.{effect['source']}"] = effect.get("p_gg")
    for pair, comparison in (t4.get("comparison") or {}).items():
        for measure, test in (comparison or {}).items():
            if isinstance(test, dict) and "p" in test:
                out[f"task4.comparison.{pair}.{measure}"] = test["p"]
                out[f"task4.comparison.{pair}.{measure}.wilcoxon"] = test.get("wilcoxon_p")
    for device, part in (t4.get("speed_accuracy") or {}).items():
        for name, test in (part or {}).items():
            if isinstance(test, dict):
                out[f"task4.speed_accuracy.{device}.{name}"] = test.get("p")
    return {k: _p(v) for k, v in sorted(out.items())}


def _p(value: Any) -> float | None:
    return None if value is None else float(value)
