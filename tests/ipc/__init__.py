"""Helpers for tests that read records as they go on the socket (server/ipc/records.py)."""


def sent(record):
    """The array `record` goes on the socket as (None: None)."""
    return None if record is None else record.to_array()


def state_map(state):
    """A state record's map as it goes on the socket: the view, then the recorder's and the
    timing's keys (None: None)."""
    return None if state is None else state.to_array()[1]


# The optional wire state fields as a loop with nothing to say about them sends them (the loop
# always sends every field; test records that name only what they test get these).
EMPTY_OPTIONAL = {"visible": {}, "events": [], "scales": {}, "stiffness": {}, "haptic": {}, "driver": None, "tools": [],
                  "points": {}, "tracking": {"lost": []}}


def loop_state(body: dict):
    """The State record of a test's state map (the optional wire fields filled as the loop fills them)."""
    from server.ipc.records import State
    return State.from_array(["state", {**EMPTY_OPTIONAL, **body}])
