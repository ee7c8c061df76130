"""The documented keys of stats.json, in one place (docs/analysis.md lists the same; a test checks
that every key here is documented there and present in a full analysis).

Paths are dotted (nested objects). `<device>` stands for a device name (fingertac, ferrovibe, …),
`[]` for every row of a list. A "description" (describe()) is an object with n_trials,
n_participants, mean, sd (over trials), ci95_low, ci95_high (t-based, over participants' means).
An analysis that could not run is null, and `skipped` says why under its dotted path.
"""

from __future__ import annotations

from typing import Any

# issue 7's keys: each resolves in a full analysis; when the data lack it, the path stops at a null
# object on the way (task1.rm_anova = null) and `skipped` names that object's path and the reason
REQUIRED = (
    "task1.rm_anova.p_gg",
    "task2.kendall_tau",
    "task3.estimation.a",
    "task3.estimation.b",
    "task3.production.a",
    "task3.production.b",
    "task4.fingertac.trajectory_length.mean",
    "task4.fingertac.completion_time.mean",
)

KEYS: dict[str, str] = {
    "format": '"viestac-analysis"',
    "format_version": "1",
    "skipped": "dotted path → why that analysis was skipped (data absent or too few)",
    "methods": "the methodological choices in words (ci, rm_anova, posthoc, kendall, power_fit, outliers, throughput, "
               "psychophysics)",
    # provenance
    "provenance.database": "the database file analysed",
    "provenance.study_id": "the study analysed",
    "provenance.study_title": "its title",
    "provenance.study_hashes": "SHA-256 of the study file(s) the sessions ran (more than one: the file changed)",
    "provenance.software_versions": "ViESTac versions that recorded the sessions",
    "provenance.analysis": "versions of ViESTac, Python and the statistics libraries of this analysis",
    "provenance.n_sessions": "sessions analysed",
    "provenance.n_participants": "distinct participant codes",
    "provenance.sessions[]": "per session: session, participant, participant_index, device, status, created_utc, "
                             "software_version, study_hash, trials, answered, excluded",
    "provenance.trial_status": "trials per status (only answered ones count)",
    "provenance.excluded_trials[]": "trials the experimenter excluded: session, participant, seq, task, kind, reason",
    "provenance.warnings": "anything that limits the comparability of the sessions",
    # task 1
    "task1.n_trials": "answered contact-angle main trials with an answer",
    "task1.n_participants": "participants among them",
    "task1.per_angle[]": "per presented angle: angle, a description of |answer − angle|, mean_signed_error",
    "task1.mean_abs_dev": "description of |answer − angle| over all trials",
    "task1.rm_anova": "one-way rm-ANOVA of the deviation over angles (see rm_anova below)",
    "task1.rm_anova.p_gg": "Greenhouse-Geisser corrected p (pingouin p_GG_corr)",
    "task1.quadratic_trend": "OLS abs_dev = b0 + b1·angle + b2·angle²: b0, b1, b2, se_*, p_* per coefficient, "
                             "F_quadratic, df_quadratic, p_quadratic (the b2 = 0 test), F_model, p_model, "
                             "df_model, r2, n",
    # rm-ANOVA objects (task1.rm_anova, task2.pairs.rm_anova, task4.<device>.rm_anova.<measure>)
    "rm_anova.within": "the within-participant factor(s)",
    "rm_anova.n_participants": "complete participants used",
    "rm_anova.n_dropped_incomplete": "participants dropped for a missing cell",
    "rm_anova.effects[]": "per effect: source, F, ddof1, ddof2, p_unc, eps, p_gg, ddof1_gg, ddof2_gg, ng2, "
                          "sphericity_W, sphericity_p (Mauchly; null when there are not more participants than "
                          "levels); a one-way ANOVA has the same keys directly on the object too",
    "rm_anova.F": "F ratio",
    "rm_anova.ddof1": "effect degrees of freedom (uncorrected)",
    "rm_anova.ddof2": "error degrees of freedom (uncorrected)",
    "rm_anova.p_unc": "uncorrected p",
    "rm_anova.eps": "Greenhouse-Geisser epsilon",
    "rm_anova.p_gg": "Greenhouse-Geisser corrected p (= p_unc with two levels)",
    "rm_anova.ddof1_gg": "eps·ddof1",
    "rm_anova.ddof2_gg": "eps·ddof2",
    "rm_anova.ng2": "generalised eta squared",
    # task 2
    "task2.pairs.n_trials": "answered texture pair trials",
    "task2.pairs.n_participants": "participants among them",
    "task2.pairs.per_comparison[]": "comparison label, first_hz, second_hz and a description of the rating",
    "task2.pairs.reference": "the same-texture comparison the post-hoc tests compare with",
    "task2.pairs.rm_anova": "rm-ANOVA of the rating over the comparisons",
    "task2.pairs.posthoc": "method, n_pairs_corrected, n_participants, tests[]: comparison, vs, A, B, T, dof, "
                           "p_unc, p_bonf, hedges_g, mean_diff (comparison − reference)",
    "task2.identification.n_trials": "answered identification trials",
    "task2.identification.n_participants": "participants among them",
    "task2.identification.crosstab": "actual_hz (rows), detected_hz (columns), counts, hit_rate[] (actual_hz, "
                                     "rate, n), accuracy",
    "task2.kendall_tau": "Kendall's tau-b of actual vs detected frequency",
    "task2.kendall_tau_p": "its two-sided p",
    "task2.kendall_tau_variant": '"tau-b"',
    "task2.kendall_tau_n": "identification trials in it",
    # task 3
    "task3.fit_method": "how the power law was fitted",
    "task3.fit_levels": "the levels the fits use (2..9)",
    "task3.estimation.n_trials": "answered estimation main trials (n_participants beside it)",
    "task3.estimation.per_level[]": "level and a description of the named level",
    "task3.estimation.a": "Stevens' a of p = a·S^b (estimation)",
    "task3.estimation.b": "Stevens' exponent b (estimation)",
    "task3.estimation.fit": "method, levels, n, n_participants, a, b, se_b, a_ci95, b_ci95, r2_log, p_b, "
                            "nls (a, b, se_a, se_b of the non-linear least-squares check)",
    "task3.production.n_trials": "production main trials with a produced level (n_participants beside it)",
    "task3.production.per_level[]": "level, a description of the produced level, match_time_s_mean",
    "task3.production.a": "Stevens' a (production)",
    "task3.production.b": "Stevens' exponent b (production)",
    "task3.production.fit": "as task3.estimation.fit",
    # task 4
    "task4.n_trials": "answered positioning main trials",
    "task4.n_participants": "participants among them",
    "task4.guidance_cues": "the cues a device's means are taken over",
    "task4.outliers": "rule, k, n_excluded, trials[] (trial_id, participant, device, cue, object, measure, "
                      "value, median, low, high)",
    "task4.conditions[]": "per device, cue and object: descriptions of every measure",
    "task4.<device>": "null when the device has no guidance trials; else n_trials, n_participants, cues, objects "
                      "and the following",
    "task4.<device>.trajectory_length": "description of the trajectory length over the device's guidance trials",
    "task4.<device>.completion_time": "description of the completion time (s)",
    "task4.<device>.helpfulness": "description of the helpfulness rating",
    "task4.<device>.end_error": "description of the end-point error (hold_error_mean)",
    "task4.<device>.by_cue[]": "per cue: descriptions of every measure",
    "task4.<device>.by_object[]": "per target object: the same",
    "task4.<device>.by_cue_object[]": "per cue and object: the same",
    "task4.<device>.rm_anova.<measure>": "rm-ANOVA over cue and/or object (whichever varies) of trajectory_length, "
                                         "completion_time, helpfulness",
    "task4.comparison.<a>_vs_<b>": "devices, note, and per measure: n_pairs, mean_<a>, mean_<b>, mean_diff, T, "
                                   "dof, p, cohen_d, diff_ci95, wilcoxon_W, wilcoxon_p",
    "task4.questionnaire.<question>": "kind choice: tasks, n, counts[] (value, n, share); kind rating: a description",
    "task4.speed_accuracy.<device>": "n_trials, time_vs_length and time_vs_end_error (Spearman rho, p, n)",
    "task4.throughput": "method, n_trials, n_conditions_skipped, conditions[] (device, cue, object, n, D, Ae, "
                        "sd_dx, We, IDe, MT, TP), by_device, by_cue (\"device/cue\" → mean TP)",
    # psychophysics (server/analysis/psychophysics.py; docs/psychophysics.md "stats.json keys").
    # <cell> is `pooled` or a row of `participants[]`
    "psychophysics.n_trials": "answered main trials with a usable psychophysics record (metrics.psy)",
    "psychophysics.n_participants": "participants among them",
    "psychophysics.n_tasks": "psychophysics tasks analysed",
    "psychophysics.families": "the psychometric families fitted (logistic, normal, gumbel, weibull)",
    "psychophysics.lapse_max": "the lapse rate's upper bound in every fit",
    "psychophysics.bootstrap_samples": "resampled data sets per parametric bootstrap",
    "psychophysics.bootstrap_seed": "the seed every bootstrap's generator starts from (with the cell's name)",
    "psychophysics.tasks[]": "per task: task, design, parameter, unit, guess, choices, n_trials, n_participants, "
                             "conditions[]",
    "psychophysics.tasks[].conditions[]": "per condition (\"main\" without interleaving): condition, n_trials, "
                                          "n_participants, family (the one of highest likelihood on the pooled data; "
                                          "null for identification), families, pooled, participants[]",
    "psychophysics.tasks[].conditions[].families": "every family's fit to the pooled data: threshold, slope, lapse, "
                                                   "deviance, log_likelihood",
    "psychophysics.tasks[].conditions[].<cell>": "participant (null when pooled), n_trials, points[], fit, "
                                                 "bootstrap, procedure_estimate, sdt, information",
    "psychophysics.tasks[].conditions[].<cell>.points[]": "per distinct level of the fitted trials: level, n (trials), "
                                                          "k (correct, or \"yes\" / \"different\"), p = k/n",
    "psychophysics.tasks[].conditions[].<cell>.fit": "family, guess, threshold (α), slope (β), lapse, "
                                                     "midpoint (the level halfway from the guess rate to 1 − lapse, "
                                                     "F = ½: comparable across families), deviance, log_likelihood, "
                                                     "converged, n_levels, n_trials (null: skipped)",
    "psychophysics.tasks[].conditions[].<cell>.bootstrap": "samples, threshold_ci95, slope_ci95, midpoint_ci95 "
                                                           "(percentile), deviance_p (share of resampled deviances ≥ the fit's)",
    "psychophysics.tasks[].conditions[].<cell>.procedure_estimate": "the procedure's estimate after the last trial "
                                                                    "(pooled: mean over participants, with "
                                                                    "procedure_estimate_n)",
    "psychophysics.tasks[].conditions[].<cell>.sdt": "yes-no and same-different: model, correction, hits, "
                                                     "signal_trials, false_alarms, noise_trials, hit_rate, "
                                                     "false_alarm_rate, d_prime, criterion",
    "psychophysics.tasks[].conditions[].<cell>.information": "identification: labels, confusion (stimulus × answer), "
                                                             "trials, accuracy, bits, corrected, correction, "
                                                             "maximum, correction_method",
}


def lookup(stats: dict, path: str) -> Any:
    """The value at a dotted path; KeyError naming the first missing part."""
    node: Any = stats
    for part in path.split("."):
        if not isinstance(node, dict) or part not in node:
            raise KeyError(f"{path}: no {part!r}")
        node = node[part]
    return node


def why_missing(stats: dict, path: str) -> str | None:
    """None if `path` holds a value; else the skip reason of the null object on the way (or of
    the path itself), or "missing" when there is none (a bug)."""
    parts = path.split(".")
    node: Any = stats
    for i, part in enumerate(parts):
        if node is None:
            return stats.get("skipped", {}).get(".".join(parts[:i]), "missing")
        if not isinstance(node, dict) or part not in node:
            return "missing"
        node = node[part]
    return None if node is not None else stats.get("skipped", {}).get(path, "missing")
