"""Who is acting: the identity a valid token stands for."""

from __future__ import annotations

import re
from dataclasses import dataclass

# admin: owns the rig, sees every site; experimenter: belongs to one site (lab); participant: joins
# one session; observer: watches the rig, no session data.
ROLES = ("admin", "experimenter", "participant", "observer")
CONTROLLERS = ("admin", "experimenter")  # the roles that may hold the control lease

SITE_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,63}$")
MAX_LABEL = 200


@dataclass(frozen=True)
class Identity:
    token_id: str
    role: str
    site: str | None = None
    session: str | None = None
    label: str = ""
    expires_at: float | None = None  # UTC seconds; None: never

    def to_dict(self) -> dict:
        """JSON-able, without any secret (the token id is not one)."""
        return {"token_id": self.token_id, "role": self.role, "site": self.site, "session": self.session,
                "label": self.label, "expires_at": self.expires_at}


def check_grant(role: str, site: str | None, session: str | None, label: str) -> None:
    """ValueError when a token of these fields makes no sense (the CLI and POST /api/tokens say why)."""
    if role not in ROLES:
        raise ValueError(f"unknown role {role!r}; expected one of {', '.join(ROLES)}")
    if site is not None and not SITE_RE.match(site):
        raise ValueError(f"site {site!r}: 1-64 letters, digits, '.', '_' or '-', starting with a letter or digit")
    if role == "admin" and site is not None:
        raise ValueError("an admin token has no site (an admin sees every site)")
    if role == "experimenter" and site is None:
        raise ValueError("an experimenter token needs a site (--site)")
    if role == "participant" and not session:
        raise ValueError("a participant token needs a session")
    if role != "participant" and session is not None:
        raise ValueError("only a participant token is bound to a session")
    if session is not None and (not isinstance(session, str) or len(session) > 200):
        raise ValueError("session: a string of at most 200 characters")
    if not isinstance(label, str) or len(label) > MAX_LABEL:
        raise ValueError(f"label: a string of at most {MAX_LABEL} characters")
