"""The frame ceiling's token bucket (server/hub/frame_ceiling.py) on an injected clock: a loop
publishing every tick is let through at most state_hz + CUE_FRAMES_PER_S a second, the cadence
and a cue change right after it at once."""

from server.hub.frame_ceiling import BURST, CUE_FRAMES_PER_S, FrameCeiling, frames_per_s

MS = 1_000_000


def sent_in_one_second(publish_every_ns: int, state_hz: float = 60.0) -> int:
    ceiling, sent = FrameCeiling(state_hz, 0), 0
    for now in range(0, 1_000_000_000, publish_every_ns):
        if ceiling.wait_ns(now) == 0:
            ceiling.spend(now)
            sent += 1
    return sent


def test_a_publish_every_tick_is_held_to_the_ceiling():
    assert frames_per_s(60.0) == 60.0 + CUE_FRAMES_PER_S
    assert frames_per_s(60.0) <= sent_in_one_second(1 * MS) <= frames_per_s(60.0) + BURST
    assert sent_in_one_second(1 * MS, state_hz=90.0) <= frames_per_s(90.0) + BURST


def test_the_cadence_alone_is_never_held_back():
    assert sent_in_one_second(16_666_667) == 60


def test_a_cue_frame_right_after_a_cadence_frame_goes_at_once_and_a_third_waits_its_slot():
    ceiling = FrameCeiling(60.0, 0)
    for now in (0, 1 * MS):
        assert ceiling.wait_ns(now) == 0
        ceiling.spend(now)
    wait = ceiling.wait_ns(2 * MS)
    assert 0 < wait <= 1e9 / frames_per_s(60.0)
    assert ceiling.wait_ns(2 * MS + wait) == 0


def test_a_clock_that_steps_back_refills_nothing():
    ceiling = FrameCeiling(60.0, 10 * MS)
    ceiling.spend(10 * MS)
    ceiling.spend(10 * MS)
    assert ceiling.wait_ns(5 * MS) > 0
