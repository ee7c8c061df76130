"""report-card.html of `viestac report devices` in headless Chromium, from file:// with no server:
every figure stats.json lists is on the page and renders with a size, every printed number shows
stats.json's value, nothing is fetched, and the full-page screenshot is not blank
(tests/artifacts/browser/report-card.png)."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest

from server.analysis.report import fmt
from server.report.run import PAGE, STATS, report_devices
from tests.browser.conftest import ARTIFACTS

pytestmark = pytest.mark.browser

FIGURES_JS = """() => [...document.querySelectorAll('figure')].map(f => {
  const img = f.querySelector('img'), r = img.getBoundingClientRect();
  return {id: f.id, complete: img.complete, natural: [img.naturalWidth, img.naturalHeight], box: [r.width, r.height],
          sources: f.querySelectorAll('.sources li').length};
})"""
NUMBERS_JS = """() => [...document.querySelectorAll('[data-stat]')].map(e =>
  [e.dataset.stat, JSON.parse(e.dataset.value), e.textContent])"""


@pytest.fixture(scope="module")
def card(report_card_battery, tmp_path_factory) -> Path:
    data = report_card_battery
    out = tmp_path_factory.mktemp("card")
    report_devices(list(data.values()), out)
    return out


def test_every_figure_renders_numbers_match_and_the_page_is_not_blank(card, browser):
    stats = json.loads((card / STATS).read_text(encoding="utf-8"))
    page = browser.new_page(viewport={"width": 1200, "height": 900})
    requests, errors = [], []
    page.on("request", lambda r: requests.append(r.url))
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("console", lambda m: m.type == "error" and errors.append(m.text))
    page.goto((card / PAGE).as_uri())
    page.wait_for_load_state("load")
    page.wait_for_function("[...document.images].every(i => i.complete)")
    shown = page.evaluate(FIGURES_JS)
    assert [f["id"] for f in shown] == [f"fig-{f['name']}" for f in stats["figures"]]
    assert len(shown) == 4
    for f, listed in zip(shown, stats["figures"]):
        assert f["complete"] and min(f["natural"]) > 0 and min(f["box"]) > 100, f
        assert f["sources"] == len(listed["sources"])
    numbers = page.evaluate(NUMBERS_JS)
    assert len(numbers) > 40
    for path, value, text in numbers:
        here = stats
        for key in path.split("."):
            here = here[int(key)] if isinstance(here, list) else here[key]
        assert here == value and text == fmt(value), path
    assert errors == []
    assert [u for u in requests if not u.startswith(("file:", "data:"))] == []
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    shot = page.screenshot(path=str(ARTIFACTS / "report-card.png"), full_page=True)
    for f in shown:  # each figure's own pixels: drawn, not an empty box
        pixels = _pixels(page.locator(f"#{f['id']} img").screenshot())
        assert pixels.std() > 10 and (pixels < 200).mean() > 0.01, f["id"]
    whole = _pixels(shot)
    assert whole.std() > 10
    page.close()


def _pixels(png: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("L"), dtype=float)
