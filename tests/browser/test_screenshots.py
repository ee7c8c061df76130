"""Screenshots of the console and the participant page at 1280×800 and 1920×1080 (issue 34), with
what a screenshot shows asserted where the DOM can say it: no horizontal overflow, no element
clipped out of its card (nor text cut off inside one), nothing overlapping the participant's
question. The pictures go to tests/artifacts/browser/screens-*.png, to be looked at.

The lab set-up (a study whose question the participant answers, a session, a join link) is
test_a11y.py's.
"""

from __future__ import annotations

import pytest

from tests.browser.conftest import ARTIFACTS
from tests.browser import test_a11y
from tests.browser.test_a11y import Console, join, join_link, open_session, question_shown, start_trial
from tests.browser.test_web_client import wait_for

pytestmark = pytest.mark.browser
lab, pages = test_a11y.lab, test_a11y.pages  # the fixtures

SIZES = ((1280, 800), (1920, 1080))

# Horizontal overflow: the page is wider than the window (a horizontal scroll bar), or a visible
# element reaches beyond the window's right edge.
OVERFLOW_JS = """() => {
  const w = document.documentElement.clientWidth;
  const out = [...document.querySelectorAll('body *')].filter((el) => {
    if (!el.checkVisibility({ visibilityProperty: true }) || el.closest('[hidden]')) return false;
    const r = el.getBoundingClientRect();
    return r.width > 0 && r.height > 0 && r.right > w + 1;
  }).map((el) => `${el.tagName.toLowerCase()}${el.id ? '#' + el.id : ''}.${el.className} right ${
    Math.round(el.getBoundingClientRect().right)}`);
  return { scroll: document.documentElement.scrollWidth, width: w, out: out.slice(0, 10) };
}"""

# Clipped: a visible element of a card that reaches outside the card's box, or text cut off by an
# overflow:hidden box without an ellipsis (a deliberate "…" is fine), or a control narrower than
# what it holds. Scrolling boxes (overflow auto/scroll) are meant to hold more: skipped.
CLIPPED_JS = """(cardSel) => {
  const found = [];
  const scrolls = (el) => ['auto', 'scroll'].includes(getComputedStyle(el).overflowX)
    || ['auto', 'scroll'].includes(getComputedStyle(el).overflowY);
  const name = (el) => `${el.tagName.toLowerCase()}${el.id ? '#' + el.id : ''}${
    el.className && typeof el.className === 'string' ? '.' + el.className.split(' ').join('.') : ''}`;
  for (const card of document.querySelectorAll(cardSel)) {
    if (!card.checkVisibility()) continue;
    const c = card.getBoundingClientRect();
    for (const el of card.querySelectorAll('*')) {
      if (!el.checkVisibility({ visibilityProperty: true })) continue;
      let inScroller = false;
      for (let p = el.parentElement; p && p !== card; p = p.parentElement) if (scrolls(p)) inScroller = true;
      if (inScroller || ['svg', 'path', 'g', 'rect', 'line', 'text', 'polyline', 'circle'].includes(el.tagName.toLowerCase())) continue;
      const r = el.getBoundingClientRect();
      if (r.width === 0 || r.height === 0) continue;
      if (r.left < c.left - 1 || r.right > c.right + 1 || r.top < c.top - 1 || r.bottom > c.bottom + 1) {
        found.push(`${name(el)} outside ${name(card)} (${Math.round(r.left)}..${Math.round(r.right)} in ${
          Math.round(c.left)}..${Math.round(c.right)})`);
        continue;
      }
      const s = getComputedStyle(el);
      const cut = s.overflowX === 'hidden' || s.overflowX === 'clip';
      if (cut && s.textOverflow !== 'ellipsis' && el.scrollWidth > el.clientWidth + 1 && el.innerText?.trim())
        found.push(`${name(el)} cuts its text (${el.scrollWidth} > ${el.clientWidth}): ${el.innerText.trim().slice(0, 60)}`);
      if (['INPUT', 'SELECT'].includes(el.tagName) && el.type !== 'checkbox' && el.type !== 'radio' && !el.readOnly
          && el.scrollWidth > el.clientWidth + 1 && el.value)
        found.push(`${name(el)} is narrower than its value ${JSON.stringify(el.value.slice(0, 40))}`);
    }
  }
  return found.slice(0, 12);
}"""

# What overlaps a box on the participant page: the other visible overlays.
OVERLAPS_JS = """(sel) => {
  const target = document.querySelector(sel);
  if (!target || target.hidden || !target.checkVisibility()) return null;
  const a = target.getBoundingClientRect();
  const hit = (b) => a.left < b.right && b.left < a.right && a.top < b.bottom && b.top < a.bottom;
  return [...document.querySelectorAll('.overlay, .overlay > *')].filter((el) =>
    el !== target && !target.contains(el) && !el.contains(target) && !el.hidden && el.checkVisibility()
    && (el.innerText ?? '').trim() !== '' && hit(el.getBoundingClientRect()))
    .map((el) => `${el.id || el.className}: ${(el.innerText ?? '').trim().slice(0, 50)}`);
}"""


def frame_of(console: Console):
    """The console's participant's view (an iframe of the participant page, as an observer)."""
    return console.page.query_selector("#scene-frame").content_frame()


def check_page(page, where: str, cards: str | None = None) -> None:
    overflow = page.evaluate(OVERFLOW_JS)
    assert overflow["scroll"] <= overflow["width"] and not overflow["out"], f"{where}: horizontal overflow {overflow}"
    if cards:
        clipped = page.evaluate(CLIPPED_JS, cards)
        assert not clipped, f"{where}: clipped {clipped}"


@pytest.mark.parametrize("width,height", SIZES)
def test_the_console_and_the_participant_page_look_right(pages, lab, width, height):
    size = {"width": width, "height": height}
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    console = Console(pages(lab, viewport=size), lab).open()
    sid = open_session(console, f"S{width}")
    participant = join(pages(lab, None, size), lab, join_link(console))
    console.page.wait_for_selector("#join-qr svg")
    check_page(console.page, f"console {width}×{height}, session open", ".c-card")
    console.page.screenshot(path=str(ARTIFACTS / f"screens-console-session-{width}x{height}.png"), full_page=True)

    start_trial(console, lab, sid, 0)
    question_shown(participant, "Which angle")
    console.page.wait_for_selector('#queue tr.c-running[data-seq="0"]')
    # the console's participant's view has drawn its scene
    wait_for(lambda: console.page.evaluate(
        "document.querySelector('#scene-frame')?.contentWindow?.__viestac?.ready === true"), timeout=20,
        what="the console's participant's view ready")
    p = participant.page
    x, y = participant.screen((0.0, 0.3, 0.5))
    p.mouse.move(x, y, steps=4)  # the participant touches the dome: the live view has something to show
    console.page.wait_for_timeout(1500)

    check_page(console.page, f"console {width}×{height}, trial running", ".c-card")
    console.page.screenshot(path=str(ARTIFACTS / f"screens-console-running-{width}x{height}.png"), full_page=True)
    console.page.screenshot(path=str(ARTIFACTS / f"screens-console-running-window-{width}x{height}.png"))

    check_page(p, f"participant {width}×{height}")
    overlaps = p.evaluate(OVERLAPS_JS, "#answer")
    assert overlaps == [], f"participant {width}×{height}: the question is covered by {overlaps}"
    box = p.locator("#answer").bounding_box()
    assert box and box["x"] >= 0 and box["y"] >= 0 and box["x"] + box["width"] <= width \
        and box["y"] + box["height"] <= height, f"the question is not all in the window: {box}"
    p.screenshot(path=str(ARTIFACTS / f"screens-participant-question-{width}x{height}.png"))

    # inside the console's participant's view: the scenario's debug text must not cover the HUD
    inner = frame_of(console).evaluate(OVERLAPS_JS, "#hud")
    assert not inner, f"console {width}×{height}: in the participant's view, the HUD is covered by {inner}"
    assert not console.page_errors and not participant.page_errors
