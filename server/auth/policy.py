"""Who may do what: one rule per REST operation and per /ws client message.

Keys are "METHOD /api/path/{param}" exactly as in /openapi.json, and "ws:<message type>" (plus
"ws:input:operator" for a control whose `who` is operator). The REST guard fails closed on an
operation without a rule, and a test checks that every operation of /openapi.json and every client
message type has one. `decide` checks role and lease; the site is the handler's: with scope "site"
it filters lists by `identity.site` and answers 404 for another site's session (admin: every site).
"""

from __future__ import annotations

from dataclasses import dataclass

from server.auth.identity import ROLES, Identity

SCOPES = ("public", "rig", "site", "self")


@dataclass(frozen=True)
class Rule:
    roles: frozenset[str]        # who may (empty: public, no token needed)
    lease: bool = False          # must hold the control lease (the rig changes)
    scope: str = "rig"           # public | rig | site (the handler filters/404s by identity.site) | self
    drive: bool = False          # ws only: the lease holder or a participant of lease.session
    recorded: bool = False       # changes what a running trial records: only its own lab and session (409)
    doc: str = ""

    def __post_init__(self):
        if not self.roles <= set(ROLES):
            raise ValueError(f"unknown roles {sorted(self.roles - set(ROLES))}")
        if self.scope not in SCOPES:
            raise ValueError(f"unknown scope {self.scope!r}")
        if (self.scope == "public") != (not self.roles):
            raise ValueError("a public rule has no roles, and only a public rule")


@dataclass(frozen=True)
class RunningTrial:
    """The trial being recorded now: its session, and that session's lab (None: a session of no
    lab, made by the admin)."""
    session: str
    site: str | None

    def outsider(self, who: Identity) -> bool:
        """Whether `who` is outside this trial: a participant of another session, or staff of another
        lab (the admin, the rig's owner, is of every lab)."""
        if who.role == "participant":
            return who.session != self.session
        return who.role != "admin" and who.site != self.site

    def own_participant(self, who: Identity) -> bool:
        """A participant of this trial's session: it may drive in its own trial whoever holds the lease."""
        return who.role == "participant" and who.session == self.session

    def refusal(self) -> str:
        lab = f"lab {self.site}" if self.site else "the admin"
        return (f"a trial of {lab} is being recorded on this rig: nothing from outside it may change what it "
                f"records until {lab} finishes or aborts it")


ANY = frozenset(ROLES)
STAFF = frozenset({"admin", "experimenter"})  # the roles that may hold the lease and read session data
ADMIN = frozenset({"admin"})
DRIVERS = frozenset({"admin", "experimenter", "participant"})

PUBLIC = Rule(frozenset(), scope="public")


def _view(doc: str) -> Rule:
    return Rule(ANY, doc=doc)


def _rig(doc: str) -> Rule:
    return Rule(STAFF, lease=True, doc=doc)


def _rig_recorded(doc: str) -> Rule:
    """A rig change that reaches a running trial's recording (the HIP, the tracker mapping): the
    lease holder, and while a trial is recorded only of that trial's lab."""
    return Rule(STAFF, lease=True, recorded=True, doc=doc)


def _site_read(doc: str) -> Rule:
    return Rule(STAFF, scope="site", doc=doc)


def _site_data(doc: str) -> Rule:
    """A change to a site's recorded data that does not move the rig: the site's staff, no lease
    (a lab whose lease expired mid-trial can still finish, abort or annotate its own session)."""
    return Rule(STAFF, scope="site", doc=doc)


def _site_rig(doc: str) -> Rule:
    return Rule(STAFF, lease=True, scope="site", doc=doc)


POLICY: dict[str, Rule] = {
    # health: for load balancers, monitors and the page before login; says nothing of sessions
    "GET /api/health": Rule(frozenset(), scope="public", doc="server and loop status"),
    # read-only views of the rig: any signed-in role (a participant's page shows the scene too)
    "GET /api/scene": _view("the current scene"),
    "GET /api/state": _view("the latest state frame"),
    "GET /api/scenarios": _view("the scenarios this server can run"),
    "GET /api/scenario": _view("the running scenario"),
    "GET /api/devices": _view("device status"),
    "GET /api/clients": _view("connected clients"),
    "GET /api/telemetry": _view("loop timing"),
    "GET /api/trackers": _view("recent tracker samples and the tracker sources' health"),
    "GET /api/lease": _view("who holds the lease, the queue"),
    # the rig changes: the lease holder only
    "POST /api/scenario": _rig("switch the scenario"),
    "POST /api/trial": _rig("start a trial"),
    "DELETE /api/trial": _rig("end the trial"),
    "POST /api/command": _rig_recorded("a key or experimenter command, as operator"),
    "POST /api/trackers/{source}/capture": _rig_recorded("capture tracked points for a calibration"),
    "PUT /api/trackers/{source}/calibration": _rig_recorded("calibrate a tracker source"),
    "DELETE /api/trackers/{source}/calibration": _rig_recorded("a tracker source back to its default calibration"),
    "POST /api/telemetry/reset": _rig("a new timing window (the numbers other labs read)"),
    # studies: the rig's study files; staff reads them to plan sessions
    "GET /api/studies": Rule(STAFF, doc="study files"),
    "GET /api/studies/{study_id}": Rule(STAFF, doc="one study"),
    "GET /api/studies/{study_id}/plan": Rule(STAFF, doc="a participant's planned trials"),
    # sessions: a site's data (404 across sites). Only starting a trial runs on the rig (the lease);
    # the rest changes the site's own records, and a running trial refuses rig changes (409) until
    # its lab finishes or aborts it, lease or not.
    "GET /api/sessions": _site_read("the site's sessions"),
    "GET /api/sessions/{session_id}": _site_read("a session with its answers"),
    "GET /api/sessions/{session_id}/control": _site_read("who controls a session"),
    "GET /api/sessions/{session_id}/tracks": _site_read("a session's psychophysics tracks"),
    "POST /api/sessions": _site_data("a new session (of the caller's site)"),
    "POST /api/sessions/{session_id}/control": _site_data("take control of a session"),
    "PUT /api/sessions/{session_id}/notes": _site_data("replace the notes"),
    "POST /api/sessions/{session_id}/trials/{seq}/start": _site_rig("start a trial"),
    "PUT /api/sessions/{session_id}/trials/{seq}/responses/{question}": _site_data("enter an answer"),
    "POST /api/sessions/{session_id}/trials/{seq}/finish": _site_data("finish a trial"),
    "POST /api/sessions/{session_id}/trials/{seq}/abort": _site_data("abort a trial"),
    "POST /api/sessions/{session_id}/trials/{seq}/exclude": _site_data("exclude a trial"),
    "POST /api/sessions/{session_id}/trials/{seq}/retry": _site_data("retry an aborted trial"),
    "POST /api/sessions/{session_id}/pacing/pause": _site_data("pause a participant-paced task"),
    "POST /api/sessions/{session_id}/pacing/resume": _site_rig("resume a participant-paced task (it starts trials)"),
    # sign-in: public, throttled per code prefix; the code is the credential
    "POST /api/auth/login": Rule(frozenset(), scope="public", doc="a login code for an admin token"),
    "POST /api/auth/join": Rule(frozenset(), scope="public", doc="a join code for a participant token"),
    "GET /api/auth/me": Rule(ANY, scope="self", doc="the caller's identity"),
    # the lease itself
    "POST /api/lease": Rule(STAFF, scope="self", doc="request the lease (granted or queued)"),
    "POST /api/lease/renew": Rule(STAFF, scope="self", doc="renew the lease or the place in the queue"),
    "DELETE /api/lease": Rule(STAFF, scope="self", doc="release the lease or leave the queue"),
    "POST /api/lease/handover": Rule(STAFF, lease=True, doc="give the lease to a queued requester"),
    "POST /api/lease/force-release": Rule(ADMIN, doc="take the lease from its holder"),
    "POST /api/join-links": Rule(STAFF, lease=True, scope="site", doc="a participant join link; opens the session"),
    "GET /api/audit": Rule(STAFF, scope="site", doc="the audit log (an experimenter: its site's)"),
    # tokens: the admin's
    "GET /api/tokens": Rule(ADMIN, doc="every token (no secrets)"),
    "POST /api/tokens": Rule(ADMIN, doc="a new token"),
    "DELETE /api/tokens/{token_id}": Rule(ADMIN, doc="revoke a token"),
    # WebXR placement (server/api/placement_routes.py): read by every page; the rig's default is the
    # lease holder's; a session's by whoever drives it (a participant's own session, or staff)
    "GET /api/placement": _view("the scene's placement in the room (WebXR)"),
    "PUT /api/placement/rig": _rig("the rig's default placement"),
    "PUT /api/placement/session": Rule(DRIVERS, scope="self", doc="the session's placement (the headset's placement step)"),
    # /ws client messages
    "ws:hello": Rule(frozenset(), scope="public", doc="the token comes in it; the role granted follows the token"),
    "ws:tracker": Rule(DRIVERS, drive=True, recorded=True, doc="drive the HIP: the lease holder or a participant of "
                       "lease.session; while a trial is recorded, its lab's holder and its session's participant"),
    "ws:input": Rule(DRIVERS, drive=True, recorded=True, doc="participant keys: the lease holder or a participant of lease.session"),
    "ws:input:operator": Rule(STAFF, lease=True, recorded=True, doc="an operator command: the lease holder"),
    # a participant's own answer (v1.5): the session is its token's (another session's cannot be named);
    # the engine takes it only while that session's trial runs and only for questions the study gives
    # the participant. No lease: the running trial is the experimenter's permission.
    "ws:answer": Rule(frozenset({"participant"}), scope="self",
                      doc="a participant token's answer to its own session's question (answered_by participant)"),
    # the page's own actuators (v1.6): any page that is not an observer's may offer them; offering moves
    # nothing on the rig (the drive rides in every page's state frames), so no lease and no session rule
    "ws:actuators": Rule(DRIVERS, doc="a page offers its actuators (WebXR controllers, gamepads): the rig's "
                         "browser device"),
}


def decide(rule: Rule, who: Identity | None, lease, running: RunningTrial | None = None) -> tuple[int, str] | None:
    """None when `who` may; else (401, reason) without a valid token, (403, reason) for the role,
    the lease or driving, (409, reason naming the trial's lab) for a `recorded` rule while `running`
    is another lab's or session's trial. The site check (404) is the handler's (scope "site")."""
    if not rule.roles:
        return None
    if who is None:
        return 401, "a valid token is needed (Authorization: Bearer, or hello.token)"
    if who.role not in rule.roles:
        return 403, f"a {who.role} may not do this (allowed: {', '.join(sorted(rule.roles))})"
    if rule.lease and not lease.holds(who):
        return 403, "this changes the rig: request the control lease first (POST /api/lease)"
    if rule.recorded and running is not None and running.outsider(who):
        return 409, running.refusal()
    if rule.drive and not lease.may_drive(who) and not (running is not None and running.own_participant(who)):
        if who.role == "participant":
            return 403, "your session is not open: wait for the experimenter"
        return 403, "driving the HIP needs the control lease"
    return None
