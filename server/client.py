"""A small client of a running server's REST API: JSON in and out, a bearer token.

`request_json` is the plain call (HTTP errors raise urllib.error.HTTPError with the status and
the server's detail); `fetch_json` is the same GET for a command line, whose every failure (no
server, a refused token, an HTTP error, an answer that is not JSON) is one ServerError line.
"""

from __future__ import annotations

import http.client
import json
import urllib.error
import urllib.parse
import urllib.request


class ServerError(Exception):
    """Why a request to a running server failed, in one line for a person."""


def request_json(url: str, method: str = "GET", *, token: str | None = None, body: dict | None = None,
                 timeout: float = 5.0):
    """`method` `url` with an optional JSON body and bearer token; the decoded JSON answer."""
    data = json.dumps(body).encode() if body is not None else None
    headers = {"Content-Type": "application/json"} if data is not None else {}
    if token:
        headers["Authorization"] = f"Bearer {token}"
    request = urllib.request.Request(url, data=data, method=method, headers=headers)
    with urllib.request.urlopen(request, timeout=timeout) as response:
        return json.loads(response.read())


def fetch_json(url: str, *, token: str | None = None, timeout: float = 5.0):
    """GET `url`'s JSON; every failure is a ServerError that says what happened in one line."""
    parts = urllib.parse.urlsplit(url)
    server = f"{parts.scheme}://{parts.netloc}"
    try:
        return request_json(url, token=token, timeout=timeout)
    except urllib.error.HTTPError as exc:  # before OSError: an HTTPError is one
        hint = " (give --token or $VIESTAC_TOKEN)" if exc.code in (401, 403) else ""
        raise ServerError(f"the server at {server} refused: {exc.code} {exc.reason}{hint}") from None
    except urllib.error.URLError as exc:
        raise ServerError(f"no server at {server} ({exc.reason})") from None
    except (OSError, http.client.HTTPException) as exc:  # timed out, reset, not speaking HTTP
        raise ServerError(f"no server at {server} ({type(exc).__name__}: {exc})") from None
    except ValueError:  # json's decode error, or bytes that are not text
        raise ServerError(f"the answer of {url} is not JSON: is {server} a ViESTac server?") from None
