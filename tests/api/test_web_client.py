"""The browser client is served from an allowlist: its pages, src/, skins/ and exactly the package
files its import maps reach; never package.json, the tests or node_modules."""

from __future__ import annotations

import asyncio
import json
import posixpath
import re
from pathlib import Path

import httpx
import pytest
from starlette.applications import Starlette

from server.api.web_client import WebClient, web_file

ROOT = Path(__file__).resolve().parents[2]
WEB = ROOT / "clients" / "web"
NEED_PACKAGES = pytest.mark.skipif(not (WEB / "node_modules" / "three").is_dir(),
                                   reason="clients/web/node_modules is not installed (npm ci)")


class Client:
    """GET through the ASGI app itself (no socket)."""

    def __init__(self):
        self.app = Starlette()
        self.app.mount("/", WebClient(directory=WEB), name="web")

    def get(self, path: str) -> httpx.Response:
        async def get() -> httpx.Response:
            async with httpx.AsyncClient(transport=httpx.ASGITransport(app=self.app), base_url="http://web") as c:
                return await c.get(path)
        return asyncio.run(get())


@pytest.fixture(scope="module")
def client():
    return Client()


def import_map(page: str) -> dict[str, str]:
    text = (WEB / page).read_text()
    return json.loads(re.search(r'<script type="importmap">(.*?)</script>', text, re.S).group(1))["imports"]


@pytest.mark.parametrize("path", ["package.json", "package-lock.json", "README.md", "node_modules/three/package.json",
                                  "node_modules/three/build/three.module.js", "test/protocol.test.js", "src/",
                                  "src/../package.json", "vendor/msgpack/../../package.json", "vendor/msgpack/index.d.ts",
                                  "vendor/three/three.cjs", "skins/../../../server/app.py"])
def test_what_is_not_the_client_is_not_served(client, path):
    assert web_file(path) is None, path
    assert client.get("/" + path).status_code == 404, path


def test_pages_code_and_skins_are_served(client):
    assert client.get("/").text == (WEB / "index.html").read_text()
    for path in ["console.html", "style.css", "console.css", "src/main.js", "src/console/console.js",
                 "skins/cork.svg"]:
        response = client.get("/" + path)
        assert response.status_code == 200 and response.content == (WEB / path).read_bytes(), path


@NEED_PACKAGES
@pytest.mark.parametrize("page", ["index.html", "console.html"])
def test_every_import_the_pages_map_is_served_with_its_relative_imports(client, page):
    """Each import-map target, and every './x' module it imports in turn, answers 200."""
    imports = import_map(page)
    assert imports and not any("node_modules" in url for url in imports.values()), imports
    todo = [url.removeprefix("./") for url in imports.values() if not url.endswith("/")]
    todo += [url.removeprefix("./") + "controls/OrbitControls.js" for url in imports.values() if url.endswith("/")]
    seen: set[str] = set()
    while todo:
        path = todo.pop()
        if path in seen:
            continue
        seen.add(path)
        response = client.get("/" + path)
        assert response.status_code == 200, path
        assert "javascript" in response.headers["content-type"], (path, response.headers["content-type"])
        folder = path.rsplit("/", 1)[0]
        for rel in re.findall(r"""(?:from|import)\s*['"](\.{1,2}/[^'"]+)['"]""", response.text):
            todo.append(posixpath.normpath(posixpath.join(folder, rel)))
    assert len(seen) > len(imports)  # the relative imports were followed too
