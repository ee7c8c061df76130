"""report.html of `viestac analyze` in headless Chromium, opened from file:// with no server: every
figure decodes and renders with a non-zero size, nothing is fetched, and a full-page screenshot
goes to tests/artifacts/browser/report.png (a static page: no WebGL, so no SwiftShader flags)."""

from __future__ import annotations

from pathlib import Path

import pytest

from server.analysis.run import analyze
from tests.browser.conftest import ARTIFACTS
from tests.analysis.thesis_data import build

pytestmark = pytest.mark.browser


FIGURES_JS = """() => [...document.querySelectorAll('figure img, svg')].map(e => {
  const r = e.getBoundingClientRect();
  return {id: (e.closest('figure') || {}).id || e.tagName, tag: e.tagName, complete: e.complete ?? true,
          natural: [e.naturalWidth ?? r.width, e.naturalHeight ?? r.height], box: [r.width, r.height]};
})"""


@pytest.fixture(scope="module")
def report(tmp_path_factory) -> Path:
    base = tmp_path_factory.mktemp("report")
    build(base / "viestac.sqlite")
    analyze(base, base / "out")
    return base / "out"


def test_every_figure_renders_and_nothing_is_fetched(report, browser):
    page = browser.new_page(viewport={"width": 1200, "height": 900})
    requests, errors = [], []
    page.on("request", lambda r: requests.append(r.url))
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("console", lambda m: m.type == "error" and errors.append(m.text))
    page.goto(report.joinpath("report.html").as_uri())
    page.wait_for_load_state("load")
    page.wait_for_function("[...document.images].every(i => i.complete)")
    shown = page.evaluate(FIGURES_JS)
    names = sorted(p.stem for p in (report / "figures").glob("*.svg"))
    assert sorted(f["id"].removeprefix("fig-") for f in shown) == names
    for f in shown:
        assert f["complete"] and min(f["natural"]) > 0 and min(f["box"]) > 100, f
    assert errors == []
    assert [u for u in requests if not u.startswith(("file:", "data:"))] == []
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / "report.png"), full_page=True)
    page.close()
