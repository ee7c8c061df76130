"""`viestac tls init`: the CA and the server certificate, verified by Python's ssl (OpenSSL)."""

from __future__ import annotations

import socket
import ssl
import stat
import threading

import pytest
from cryptography import x509

from server import tls
from server.cli import main


def serve_once(cert, key) -> tuple[int, threading.Thread]:
    """A TLS listener on 127.0.0.1 that completes one handshake."""
    ctx = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
    ctx.load_cert_chain(cert, key)
    listener = socket.create_server(("127.0.0.1", 0))

    def run():
        with listener:
            conn, _ = listener.accept()
            try:
                with ctx.wrap_socket(conn, server_side=True) as s:
                    s.recv(1)
            except (ssl.SSLError, OSError):
                pass
    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return listener.getsockname()[1], thread


def handshake(port: int, ca, server_name: str) -> None:
    """Raises ssl.SSLCertVerificationError unless the chain and the name verify against `ca`."""
    ctx = ssl.create_default_context(cafile=str(ca))  # check_hostname and CERT_REQUIRED by default
    with socket.create_connection(("127.0.0.1", port), timeout=5) as raw:
        with ctx.wrap_socket(raw, server_hostname=server_name):
            pass


@pytest.fixture
def issued(tmp_path):
    return tls.init(tmp_path / "tls", ["localhost", "rig.local"], ["127.0.0.1", "192.168.1.20", "::1"])


def test_files_and_key_modes(issued):
    for which in ("ca_key", "key"):
        assert stat.S_IMODE(issued.path(which).stat().st_mode) == 0o600
    assert tls.certificate_names(issued.path("cert")) == ["localhost", "rig.local", "127.0.0.1", "192.168.1.20", "::1"]
    ca = x509.load_pem_x509_certificate(issued.path("ca").read_bytes())
    assert ca.extensions.get_extension_for_class(x509.BasicConstraints).value.ca
    assert issued.new_ca


@pytest.mark.parametrize("name", ["localhost", "rig.local", "127.0.0.1"])
def test_a_client_trusting_the_ca_verifies_the_server_and_its_name(issued, name):
    port, thread = serve_once(issued.path("cert"), issued.path("key"))
    handshake(port, issued.path("ca"), name)
    thread.join(5)


def test_a_name_not_in_the_certificate_fails_verification(issued):
    port, thread = serve_once(issued.path("cert"), issued.path("key"))
    with pytest.raises(ssl.SSLCertVerificationError):
        handshake(port, issued.path("ca"), "evil.example")
    thread.join(5)


def test_another_ca_does_not_verify(issued, tmp_path):
    other = tls.init(tmp_path / "other", ["localhost"], [])
    port, thread = serve_once(issued.path("cert"), issued.path("key"))
    with pytest.raises(ssl.SSLCertVerificationError):
        handshake(port, other.path("ca"), "localhost")
    thread.join(5)


def test_reissuing_keeps_the_ca_so_headsets_trust_the_new_certificate(issued):
    ca_before = issued.path("ca").read_bytes()
    again = tls.init(issued.directory, ["localhost", "rig.local"], ["192.168.1.77"])  # a new DHCP address
    assert not again.new_ca and again.path("ca").read_bytes() == ca_before
    port, thread = serve_once(again.path("cert"), again.path("key"))
    handshake(port, again.path("ca"), "192.168.1.77")
    thread.join(5)


def test_the_ca_is_constrained_to_the_rig_names_and_private_addresses(issued):
    with pytest.raises(ValueError, match="does not cover www.example.com"):
        tls.init(issued.directory, ["www.example.com"], [])
    with pytest.raises(ValueError, match="8.8.8.8"):
        tls.init(issued.directory, ["localhost"], ["8.8.8.8"])
    fresh = tls.init(issued.directory, ["www.example.com"], [], new_ca=True)
    assert fresh.new_ca


def test_a_certificate_outside_the_constraints_fails_even_if_signed_by_the_ca(issued, tmp_path, monkeypatch):
    """Even with the CA's key, a certificate for a public name does not verify (RFC 5280 name
    constraints, checked by OpenSSL): our own refusal is switched off to issue one."""
    from server.tls import FILES

    forged = tmp_path / "forged"
    forged.mkdir()
    for which in ("ca", "ca_key"):
        (forged / FILES[which]).write_bytes(issued.path(which).read_bytes())
    monkeypatch.setattr(tls, "_covered", lambda *_: [])
    out = tls.init(forged, ["www.example.com"], [])
    assert not out.new_ca
    port, thread = serve_once(out.path("cert"), out.path("key"))
    with pytest.raises(ssl.SSLCertVerificationError):
        handshake(port, issued.path("ca"), "www.example.com")
    thread.join(5)


def test_cli_tls_init(tmp_path, capsys):
    assert main(["tls", "init", "--dir", str(tmp_path / "t"), "--no-defaults", "--name", "rig.local",
                 "--ip", "10.0.0.5"]) == 0
    out = capsys.readouterr().out
    assert "rig.local" in out and "10.0.0.5" in out and "--tls-cert" in out
    assert tls.certificate_names(tmp_path / "t" / "server.pem") == ["rig.local", "10.0.0.5"]
    assert tls.spki_sha256(tmp_path / "t" / "server.pem") in out
