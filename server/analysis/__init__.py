"""Statistics of recorded studies (`viestac analyze`, docs/analysis.md): the thesis's chapter-5
analyses, from the experiment database to stats.json, figures and a self-contained report.html.

Modules: load (database → frames), stats (library wrappers), task1..task4 (one per task, pure
functions of DataFrames), fitts (ISO 9241-411 throughput), figures, report, keys (the documented
stats.json keys), run (the whole pipeline).
"""
