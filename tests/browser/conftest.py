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


# -- access (issue 19): pages log in with the harness's admin token --------------------------------

TOKEN_KEY = "viestac.token"  # clients/web/src/auth.js TOKEN_KEY


def admin_token(base_url: str) -> str | None:
    """The admin token the harness (tests/live_server.py) gave that server."""
    from tests.live_server import admin_token as registered

    return registered(base_url)


def auth_header(base_url: str) -> dict[str, str]:
    token = admin_token(base_url)
    return {"Authorization": f"Bearer {token}"} if token else {}


def log_in(ctx, token: str | None) -> None:
    """Every page of `ctx` (and its iframes) starts with `token` as the console's token, as if
    logged in through a login link."""
    if token:
        ctx.add_init_script(f"try {{ localStorage.setItem({TOKEN_KEY!r}, {token!r}); }} catch (e) {{}}")


def new_context(browser, base_url: str, *, token: str | None | bool = True, **kwargs):
    """A browser context logged in as the harness's admin of `base_url` (token=True), as a given
    token, or not at all (token=None). The pages' Content-Security-Policy (no 'unsafe-eval') is
    bypassed: Playwright's wait_for_function polls a string through eval; tests/transport checks
    that the pages themselves run under the policy with no violation."""
    kwargs.setdefault("bypass_csp", True)
    ctx = browser.new_context(**kwargs)
    log_in(ctx, admin_token(base_url) if token is True else token)
    return ctx
