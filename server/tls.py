"""`viestac tls init`: a local certificate authority and a server certificate for the rig.

A headset on the LAN needs a secure context for WebXR, so the rig serves HTTPS/WSS with a
certificate its browsers trust. No public CA issues one for a LAN name or a private IP, so the
rig makes its own CA once; each headset or browser trusts `ca.pem` once, and the server
certificate can be issued again (new names, a new IP from DHCP) without touching the headsets.

The CA is name-constrained (RFC 5280 §4.2.1.10) to the rig's own names, `.local` names and
private, loopback and link-local addresses: a copy of its key cannot vouch for any public site
on a headset that trusts it. Keys are written 0600. X.509 work is the `cryptography` package's.
"""

from __future__ import annotations

import datetime
import ipaddress
import os
import socket
from dataclasses import dataclass
from pathlib import Path

CA_DAYS = 3650
SERVER_DAYS = 397  # browsers refuse longer validity for publicly trusted certificates; stay within it
PRIVATE_NETWORKS = ("10.0.0.0/8", "172.16.0.0/12", "192.168.0.0/16", "127.0.0.0/8", "169.254.0.0/16",
                    "100.64.0.0/10", "::1/128", "fc00::/7", "fe80::/10")
FILES = {"ca": "ca.pem", "ca_key": "ca.key", "cert": "server.pem", "key": "server.key"}


@dataclass(frozen=True)
class Issued:
    directory: Path
    names: tuple[str, ...]
    ips: tuple[str, ...]
    new_ca: bool

    def path(self, which: str) -> Path:
        return self.directory / FILES[which]


def lan_addresses() -> list[str]:
    """The machine's IP addresses (every interface, loopback included; link-local v6 left out:
    it needs a zone index a URL cannot carry portably)."""
    import psutil

    out = []
    for addrs in psutil.net_if_addrs().values():
        for a in addrs:
            if a.family.name in ("AF_INET", "AF_INET6"):
                ip = ipaddress.ip_address(a.address.split("%")[0])
                if not (ip.version == 6 and ip.is_link_local):
                    out.append(str(ip))
    return sorted(set(out), key=lambda s: (":" in s, s))


def machine_names() -> list[str]:
    """This machine's own names, as a LAN browser may type them (mDNS adds `.local`)."""
    name = socket.gethostname().lower().rstrip(".")
    short = name.split(".")[0]
    return sorted({name, short, short + ".local"})


def default_names() -> list[str]:
    return ["localhost", *machine_names()]


def _write_private(path: Path, data: bytes) -> None:
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "wb") as f:
        f.write(data)
    os.chmod(path, 0o600)  # an existing file keeps its old mode through O_CREAT


def _covered(ca, names: list[str], ips: list[str]) -> list[str]:
    """The names and IPs the CA's name constraints do not permit (empty: all covered)."""
    from cryptography import x509

    try:
        nc = ca.extensions.get_extension_for_class(x509.NameConstraints).value
    except x509.ExtensionNotFound:
        return []
    dns = [g.value for g in nc.permitted_subtrees or () if isinstance(g, x509.DNSName)]
    nets = [g.value for g in nc.permitted_subtrees or () if isinstance(g, x509.IPAddress)]
    missing = [n for n in names if not any(n == d or n.endswith("." + d) for d in dns)]
    missing += [i for i in ips if not any(ipaddress.ip_address(i) in net for net in nets)]
    return missing


def init(directory: Path, names: list[str], ips: list[str], *, new_ca: bool = False,
         now: datetime.datetime | None = None) -> Issued:
    """Make the CA (unless one is there and `new_ca` is false) and issue the server certificate
    for `names` (DNS) and `ips`. ValueError when the existing CA cannot cover a name."""
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

    now = now or datetime.datetime.now(datetime.timezone.utc)
    names = list(dict.fromkeys(n.lower().rstrip(".") for n in names))
    ips = list(dict.fromkeys(str(ipaddress.ip_address(i)) for i in ips))
    if not names and not ips:
        raise ValueError("no names or IP addresses to issue the certificate for")
    directory.mkdir(parents=True, exist_ok=True)
    ca_path, ca_key_path = directory / FILES["ca"], directory / FILES["ca_key"]
    pem = serialization.Encoding.PEM
    made_ca = new_ca or not (ca_path.exists() and ca_key_path.exists())
    if made_ca:
        ca_key = ec.generate_private_key(ec.SECP256R1())
        subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, f"ViESTac rig CA ({names[0] if names else ips[0]})"),
                             x509.NameAttribute(NameOID.ORGANIZATION_NAME, "ViESTac")])
        permitted = [x509.DNSName(n) for n in dict.fromkeys([*names, "local", "localhost"])]
        permitted += [x509.IPAddress(ipaddress.ip_network(n)) for n in PRIVATE_NETWORKS]
        permitted += [x509.IPAddress(ipaddress.ip_network(i)) for i in ips
                      if not any(ipaddress.ip_address(i) in ipaddress.ip_network(n) for n in PRIVATE_NETWORKS)]
        ca = (x509.CertificateBuilder().subject_name(subject).issuer_name(subject)
              .public_key(ca_key.public_key()).serial_number(x509.random_serial_number())
              .not_valid_before(now - datetime.timedelta(minutes=5))
              .not_valid_after(now + datetime.timedelta(days=CA_DAYS))
              .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
              .add_extension(x509.KeyUsage(digital_signature=False, content_commitment=False, key_encipherment=False,
                                           data_encipherment=False, key_agreement=False, key_cert_sign=True,
                                           crl_sign=True, encipher_only=False, decipher_only=False), critical=True)
              .add_extension(x509.NameConstraints(permitted_subtrees=permitted, excluded_subtrees=None), critical=True)
              .add_extension(x509.SubjectKeyIdentifier.from_public_key(ca_key.public_key()), critical=False)
              .sign(ca_key, hashes.SHA256()))
        _write_private(ca_key_path, ca_key.private_bytes(pem, serialization.PrivateFormat.PKCS8,
                                                         serialization.NoEncryption()))
        ca_path.write_bytes(ca.public_bytes(pem))
    else:
        ca = x509.load_pem_x509_certificate(ca_path.read_bytes())
        ca_key = serialization.load_pem_private_key(ca_key_path.read_bytes(), password=None)
        missing = _covered(ca, names, ips)
        if missing:
            raise ValueError(f"the CA in {directory} does not cover {', '.join(missing)} "
                             "(--new-ca makes a new one; every headset must then trust it again)")
    key = ec.generate_private_key(ec.SECP256R1())
    alt = [x509.DNSName(n) for n in names] + [x509.IPAddress(ipaddress.ip_address(i)) for i in ips]
    cert = (x509.CertificateBuilder()
            .subject_name(x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, names[0] if names else ips[0])]))
            .issuer_name(ca.subject).public_key(key.public_key()).serial_number(x509.random_serial_number())
            .not_valid_before(now - datetime.timedelta(minutes=5))
            .not_valid_after(now + datetime.timedelta(days=SERVER_DAYS))
            .add_extension(x509.SubjectAlternativeName(alt), critical=False)
            .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
            .add_extension(x509.KeyUsage(digital_signature=True, content_commitment=False, key_encipherment=False,
                                         data_encipherment=False, key_agreement=False, key_cert_sign=False,
                                         crl_sign=False, encipher_only=False, decipher_only=False), critical=True)
            .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH]), critical=False)
            .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(ca_key.public_key()), critical=False)
            .sign(ca_key, hashes.SHA256()))
    _write_private(directory / FILES["key"], key.private_bytes(pem, serialization.PrivateFormat.PKCS8,
                                                               serialization.NoEncryption()))
    (directory / FILES["cert"]).write_bytes(cert.public_bytes(pem))
    return Issued(directory, tuple(names), tuple(ips), made_ca)


def certificate_names(path: Path) -> list[str]:
    """The DNS names and IP addresses a certificate's subjectAltName lists."""
    from cryptography import x509

    cert = x509.load_pem_x509_certificate(Path(path).read_bytes())
    try:
        alt = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    except x509.ExtensionNotFound:
        return []
    return [*alt.get_values_for_type(x509.DNSName), *(str(i) for i in alt.get_values_for_type(x509.IPAddress))]


def spki_sha256(path: Path) -> str:
    """base64 SHA-256 of a certificate's public key info (what Chromium's SPKI pinning flags take)."""
    import base64
    import hashlib

    from cryptography import x509
    from cryptography.hazmat.primitives import serialization

    cert = x509.load_pem_x509_certificate(Path(path).read_bytes())
    spki = cert.public_key().public_bytes(serialization.Encoding.DER, serialization.PublicFormat.SubjectPublicKeyInfo)
    return base64.b64encode(hashlib.sha256(spki).digest()).decode()
