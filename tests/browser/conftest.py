"""The one headless Chromium of the browser tests (Debian's chromium, driven by Playwright)."""

from __future__ import annotations

from pathlib import Path

import pytest

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--headless=new",
    "--no-sandbox",
    "--use-angle=swiftshader",       # WebGL without a GPU (Chromium 137+ needs the unsafe flag too)
    "--enable-unsafe-swiftshader",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]
ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "tests" / "artifacts" / "browser"
WEB_DEPS = [ROOT / "clients/web/node_modules/three/build/three.module.js",
            ROOT / "clients/web/node_modules/@msgpack/msgpack/dist.esm/index.mjs"]


def require_web_deps() -> None:
    """The web client's npm packages are installed (the pages import them)."""
    missing = [str(p.relative_to(ROOT)) for p in WEB_DEPS if not p.exists()]
    assert not missing, f"web client dependencies missing ({missing}): run `cd clients/web && npm ci`"


@pytest.fixture(scope="module")
def browser():
    if not CHROMIUM.exists():
        pytest.skip(f"{CHROMIUM} is missing (apt-get install chromium); browser tests need it")
    sync_api = pytest.importorskip("playwright.sync_api")
    with sync_api.sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        try:
            yield b
        finally:
            b.close()
