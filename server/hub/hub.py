"""The WebSocket hub: clients in, state frames out, never in the loop's way.

The hub is a composition of parts with one job each; one thread owns them all, the event
loop's (server/hub/owner.py):
- `control` (server/hub/control.py): the one owner of which scenario runs; checks every key,
  command, switch and trial before it reaches the loop;
- `fanout` (server/hub/fanout.py): the clients' sockets, protocol sessions (server/hub/session.py)
  and senders, and what every client is sent (state, scene, health, lease);
- `link` (server/hub/loop_link.py): records from the loop to the parts that act on them, records
  to the loop (and those retried), the device reports, the listeners (the recorder);
- `health_feed` (server/hub/health_feed.py): health from the children, devices, trackers and faults;
- `answers` (server/hub/answers.py): a participant's study answers and what it is asked;
- `actuators` (server/hub/browser_actuators.py): the rig's browser device, the participant pages'
  own actuators, whose drive rides in the state frames.
What a client's session asks (`forward`) goes to the loop, the scenario control or the answers.
Who may stay connected is checked here across connections: a token revoked or expired ends its
connections (`check_tokens`), and a participant session opened in a second tab takes it from the
first (`_welcomed`).
"""

from __future__ import annotations

from typing import Callable

from server.core.scenario import ParamError
from server.hub.answers import AnswerBroker
from server.hub.browser_actuators import BrowserActuators
from server.hub.control import BusyError, ScenarioControl
from server.hub.fanout import Connection, Fanout
from server.hub.health_feed import HealthFeed
from server.hub.loop_link import LoopLink
from server.hub.owner import Owner
from server.hub.session import ActuatorsOffered, Command, ParticipantAnswer, ServerInfo, ToLoop
from server.ipc.records import Record


class Hub:
    """`send_to_loop(record) -> bool`: the loop supervisor's send (False: the mailbox is full).
    `access`: the server's AccessControl (server/auth); without one no client is admitted.
    `owner`: shared with the supervisor and the device host (the app's)."""

    def __init__(self, *, server_name: str, tick_hz: int, state_hz: float, overrun_threshold: int = 10,
                 send_to_loop: Callable[[Record], bool] = lambda record: False, access=None,
                 owner: Owner | None = None):
        self.owner = owner or Owner("the hub")
        self.fanout = Fanout(self.owner, ServerInfo(server_name, tick_hz, state_hz), access=access,
                             forward=self.forward, on_welcomed=self._welcomed)
        self.answers = AnswerBroker(self.owner, self.fanout.connections)
        self.health_feed = HealthFeed(self.owner, publish=self.fanout.set_health,
                                      scenario_cls=lambda: self.control.scenario_cls,
                                      requires=lambda cls: self.control.requires(cls),
                                      overrun_threshold=overrun_threshold)
        self.control = ScenarioControl(send_to_loop, lambda: self.health_feed.device_profiles,
                                       lambda: self.health_feed.device_statuses)
        self.actuators = BrowserActuators(on_change=lambda: self.link.browser_changed())
        self.link = LoopLink(self.owner, send_to_loop, control=self.control, fanout=self.fanout,
                             health_feed=self.health_feed, tick_hz=tick_hz, actuators=self.actuators)
        self.health_feed.hub_devices = self.actuators.statuses

    def _welcomed(self, c: Connection) -> None:
        """A client was just welcomed: its `ask`, and if it is a participant connection of a session
        that another connection has, the newer one takes the session (the older only watches)."""
        self.answers.offer_ask(c)
        self.fanout.event_log.name_actor(c.session.id, c.session.identity)  # its inputs name its token
        session = c.session.asks_for
        if session is None:
            return
        for other in list(self.fanout.connections.values()):
            if other is not c and other.session.asks_for == session and other.session.replaced_by is None:
                self.forward(other, other.session.withdraw("taken", c.session.id))
                other.wake.set()

    def check_tokens(self, standing: Callable[[str], str | None] | None, now_s: float) -> int:
        """Ends the connections whose token no longer counts: expired by its expiry time (compared
        in memory, on every call: the app calls this every 0.25 s), or revoked or expired in the
        store (`standing(token_id)`, asked once per token, only when access control says tokens
        changed: a revocation here or by the CLI). Returns how many connections it ended."""
        self.owner.check()
        asked: dict[str, str | None] = {}
        ended = 0
        for c in list(self.fanout.connections.values()):
            who = c.session.identity
            if who is None or c.session.closing:
                continue
            why = "expired" if who.expires_at is not None and now_s >= who.expires_at else None
            if why is None and standing is not None:
                if who.token_id not in asked:
                    asked[who.token_id] = standing(who.token_id)
                why = asked[who.token_id]
            if why is not None:
                self.forward(c, c.session.withdraw(why))
                c.wake.set()
                ended += 1
        return ended

    def forward(self, c: Connection, events: list[ToLoop | Command | ParticipantAnswer | ActuatorsOffered]) -> None:
        """What a client's session asks of the loop; refusals go back to the client as errors."""
        for event in events:
            if isinstance(event, ActuatorsOffered):  # the page is the rig's browser device
                self.actuators.offer(event.client_id, event.actuators, event.note, left=event.left)
                continue
            if isinstance(event, ParticipantAnswer):
                self.answers.answer(c, event)
                continue
            if isinstance(event, ToLoop):
                if not self.link.send_to_loop(event.record):
                    if event.busy:
                        c.session.reply_error("busy", event.busy)
                    else:  # nobody to tell (a client left: tracker_gone): it must still arrive
                        self.link.undelivered.append(event.record)
                continue
            if event.role == "operator" and self.control.is_operator_command(event.key):
                refusal = c.session.refusal("input:operator")  # experimenter commands need the lease
                if refusal is not None:
                    c.session.reply_error("forbidden", refusal)
                    continue
            try:
                self.control.command(event.key, event.action, event.value, role=event.role,
                                     client_id=event.client_id)
            except PermissionError as exc:
                c.session.reply_error("forbidden", str(exc))
            except ParamError as exc:
                c.session.reply_error("bad_message", str(exc))
            except BusyError as exc:
                c.session.reply_error("busy", str(exc))
