"""Access control for the I/O-free session tests: real identities and a real lease
(server/auth), a dictionary for the token book, an injected clock."""

from __future__ import annotations

from server.auth.identity import Identity
from server.auth.lease import Lease
from server.auth import Unauthorized
from server.hub.session import Gate

NOW = 1_767_225_600.0  # UTC seconds; the lease's clock in these tests


class Clock:
    def __init__(self, t: float = NOW):
        self.t = t

    def __call__(self) -> float:
        return self.t


ADMIN = Identity("adm00001", "admin", label="env")
EXP_A = Identity("expa0001", "experimenter", site="lab-a", label="Anna")
EXP_B = Identity("expb0001", "experimenter", site="lab-b", label="Ben")
PART_1 = Identity("par00001", "participant", site="lab-a", session="s-1")
PART_2 = Identity("par00002", "participant", site="lab-a", session="s-2")
OBSERVER = Identity("obs00001", "observer", site="lab-a")
TOKENS = {"admin-secret": ADMIN, "exp-a-secret": EXP_A, "exp-b-secret": EXP_B, "part-1-secret": PART_1,
          "part-2-secret": PART_2, "observer-secret": OBSERVER}
SECRET = {who.token_id: secret for secret, who in TOKENS.items()}
ADMIN_SECRET = "admin-secret"


def gate(lease: Lease | None = None, admit=lambda who: None) -> tuple[Gate, Lease]:
    """A gate over TOKENS and `lease` (default: a fresh one that ADMIN holds)."""
    if lease is None:
        lease = Lease(60.0, clock=Clock())
        lease.request(ADMIN)

    def authenticate(secret: str | None) -> Identity:
        who = TOKENS.get(secret or "")
        if who is None:
            raise Unauthorized("unknown, expired or revoked token" if secret else "no token")
        return who
    return Gate(authenticate, lambda: lease, admit), lease


class FakeAccess:
    """What the hub uses of server.auth.AccessControl: authenticate a secret (per peer), the
    lease, and the hook the hub installs for lease changes."""

    def __init__(self, lease: Lease | None = None):
        self.gate, self.lease = gate(lease)
        self.on_lease_change = None
        self.peers: list[str] = []

    def authenticate(self, secret: str | None, peer: str):
        self.peers.append(peer)
        return self.gate.authenticate(secret)

    def lease_changed(self) -> None:
        self.on_lease_change(self.lease.snapshot())


def with_token(message: dict, secret: str = ADMIN_SECRET) -> dict:
    """`message` (a hello) with a token."""
    return {**message, "token": secret}
