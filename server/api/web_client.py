"""The browser client's files, served from an allowlist.

`clients/web` also holds `package.json`, its lock file, tests and the whole `node_modules` tree;
none of that is the client, so only these are served:
- the two pages and their style sheets, and everything under `src/` and `skins/`;
- `vendor/…`: the few files of the npm packages the pages import (their import maps point
  here): three.js's ES module build (which imports `three.core.js` beside it), its
  OrbitControls, msgpack's ES modules (`.mjs`, which import each other by relative path), and
  the WebXR emulator's one-file bundle (iwer: tests and the XR bench; a page imports it only
  when its URL asks, src/xr_emulator.js);
- `vendor/swagger-ui/…` and `vendor/redoc/…`: the API documentation's pages, /docs (Swagger UI)
  and /redoc (ReDoc), load their scripts and styles from here, not from a CDN: a rig on a lab
  network has none (`install_docs`, FastAPI's own page helpers pointed at these URLs).
Anything else is a 404, whatever exists on disk.
"""

from __future__ import annotations

import posixpath

from fastapi import FastAPI
from fastapi.openapi.docs import get_redoc_html, get_swagger_ui_html
from starlette.exceptions import HTTPException
from starlette.responses import Response
from starlette.staticfiles import StaticFiles
from starlette.types import Scope

PAGES = frozenset({"index.html", "console.html", "style.css", "console.css"})
TREES = ("src/", "skins/")
# URL path → file, relative to the web root.
VENDOR_FILES = {
    "vendor/three/three.module.js": "node_modules/three/build/three.module.js",
    "vendor/three/three.core.js": "node_modules/three/build/three.core.js",
    "vendor/three/addons/controls/OrbitControls.js": "node_modules/three/examples/jsm/controls/OrbitControls.js",
    # the WebXR emulator: imported only by a page whose URL asks for it (src/xr_emulator.js)
    "vendor/iwer/iwer.module.js": "node_modules/iwer/build/iwer.module.js",
    # the API documentation pages (/docs, /redoc): served here so that they work offline
    "vendor/swagger-ui/swagger-ui-bundle.js": "node_modules/swagger-ui-dist/swagger-ui-bundle.js",
    "vendor/swagger-ui/swagger-ui.css": "node_modules/swagger-ui-dist/swagger-ui.css",
    "vendor/swagger-ui/favicon-32x32.png": "node_modules/swagger-ui-dist/favicon-32x32.png",
    "vendor/redoc/redoc.standalone.js": "node_modules/redoc/bundles/redoc.standalone.js",
}
DOCS_URL, REDOC_URL = "/docs", "/redoc"
FAVICON = "/vendor/swagger-ui/favicon-32x32.png"
# URL folder → (folder, the one file suffix served from it)
VENDOR_TREES = {"vendor/msgpack/": ("node_modules/@msgpack/msgpack/dist.esm/", ".mjs")}


def web_file(path: str) -> str | None:
    """The file (relative to the web root) that serves URL path `path`, or None: not served.

    `path` is relative to the mount, '/'-separated; '..' and '.' parts are resolved first, so
    nothing outside the allowlist is reachable through them."""
    path = posixpath.normpath("/" + path).lstrip("/")
    if path in ("", "."):
        return "index.html"
    if path in PAGES or (path.startswith(TREES) and not path.endswith("/")):
        return path
    if path in VENDOR_FILES:
        return VENDOR_FILES[path]
    for url, (folder, suffix) in VENDOR_TREES.items():
        if path.startswith(url) and path.endswith(suffix):
            return folder + path[len(url):]
    return None


class WebClient(StaticFiles):
    """StaticFiles over the web root that serves only `web_file`'s allowlist."""

    async def get_response(self, path: str, scope: Scope) -> Response:
        served = web_file(path)
        if served is None:
            raise HTTPException(status_code=404)
        return await super().get_response(served, scope)


def install_docs(app: FastAPI) -> None:
    """/docs (Swagger UI) and /redoc (ReDoc) with their assets from `vendor/` above, never a CDN.
    The app is made with docs_url=None and redoc_url=None; these take their place."""
    title = f"{app.title} API"

    @app.get(DOCS_URL, include_in_schema=False)
    async def swagger_ui():
        return get_swagger_ui_html(openapi_url=app.openapi_url, title=title,
                                   swagger_js_url="/vendor/swagger-ui/swagger-ui-bundle.js",
                                   swagger_css_url="/vendor/swagger-ui/swagger-ui.css", swagger_favicon_url=FAVICON)

    @app.get(REDOC_URL, include_in_schema=False)
    async def redoc():
        return get_redoc_html(openapi_url=app.openapi_url, title=title,
                              redoc_js_url="/vendor/redoc/redoc.standalone.js", redoc_favicon_url=FAVICON,
                              with_google_fonts=False)
