"""The serve options of the transport: the banner line harnesses parse, the link host, the
exposure warning's trigger, and the TLS settings checks."""

from __future__ import annotations

import re

import pytest

from server import tls
from server.cli import build_parser, exposure_warning, is_loopback, link_base, serve_banner
from server.config import Settings

HARNESS = re.compile(r"on (https?://\S+?)/ ")  # what the test and bench harnesses look for


def test_the_banner_keeps_its_shape_on_http_and_https(tmp_path):
    issued = tls.init(tmp_path / "tls", ["localhost"], ["127.0.0.1"])
    plain = serve_banner(Settings(tracker_udp="off"), 8123)
    assert HARNESS.search(plain).group(1) == "http://127.0.0.1:8123" and "ws://127.0.0.1:8123/ws" in plain
    secure = serve_banner(Settings(tracker_udp="off", tls_cert=issued.path("cert"), tls_key=issued.path("key")), 8123)
    assert HARNESS.search(secure).group(1) == "https://127.0.0.1:8123" and "wss://127.0.0.1:8123/ws" in secure
    assert HARNESS.search(serve_banner(Settings(host="::1", tracker_udp="off"), 9)).group(1) == "http://[::1]:9"


def test_the_login_link_names_a_host_the_certificate_holds(tmp_path):
    issued = tls.init(tmp_path / "tls", ["rig.local"], ["192.168.1.20"], new_ca=True)
    cert = {"tls_cert": issued.path("cert"), "tls_key": issued.path("key")}
    assert link_base(Settings(host="0.0.0.0", tracker_udp="off", **cert), 8443) == "https://rig.local:8443"
    assert link_base(Settings(host="0.0.0.0", tracker_udp="off"), 8000) == "http://localhost:8000"
    assert link_base(Settings(host="127.0.0.1", tracker_udp="off"), 8000) == "http://127.0.0.1:8000"


def test_only_non_loopback_addresses_are_exposed():
    assert is_loopback("127.0.0.1") and is_loopback("::1") and is_loopback("localhost") and is_loopback("127.0.0.2")
    assert not is_loopback("0.0.0.0") and not is_loopback("::") and not is_loopback("192.168.1.20")
    text = exposure_warning("0.0.0.0", 8000)
    assert "0.0.0.0:8000" in text and "tokens" in text and "viestac tls init" in text


def test_tls_settings_are_checked_at_start(tmp_path):
    with pytest.raises(ValueError, match="go together"):
        Settings(tracker_udp="off", tls_cert=tmp_path / "x.pem")
    with pytest.raises(ValueError, match="does not exist"):
        Settings(tracker_udp="off", tls_cert=tmp_path / "x.pem", tls_key=tmp_path / "x.key")
    assert Settings(tracker_udp="off").scheme == "http"


def test_serve_parses_the_transport_options():
    args = build_parser().parse_args(["serve", "--tls-cert", "c.pem", "--tls-key", "k.pem", "--allow-host", "rig.lab",
                                      "--allow-host", "*.lab.example", "--allow-origin", "https://console.lab",
                                      "--no-login-link"])
    assert (args.tls_cert, args.tls_key, args.allow_host, args.allow_origin, args.no_login_link) == \
        ("c.pem", "k.pem", ["rig.lab", "*.lab.example"], ["https://console.lab"], True)
