"""The tool: the tracker rule (one driver, DRIVER_QUIET_S take-over, home when the driver leaves),
the held position, and the reuse of the god-object's fixed point."""

from server.core.haptics.primitives import Body, Plane, Pose
from server.core.tool import DEFAULT_PROXY_RADIUS, DRIVER_QUIET_S, Tool

HOME = (0.0, 0.0, 1.0)


def test_the_first_source_drives_and_others_are_ignored_and_counted():
    tool = Tool(HOME)
    assert tool.driver is None and tool.hip == HOME and tool.proxy_radius == DEFAULT_PROXY_RADIUS
    assert tool.offer("udp:h:1", 3, (0.1, 0.0, 0.5), 0.0)
    assert not tool.offer(7, 0, (0.9, 0.0, 0.5), 0.1)
    assert not tool.offer(7, 1, (0.9, 0.0, 0.5), 0.2)
    assert tool.offer("udp:h:1", 4, (0.2, 0.0, 0.5), 0.3)
    assert (tool.driver, tool.seq, tool.tracked) == ("udp:h:1", 4, (0.2, 0.0, 0.5))
    assert tool.ignored == {7: 2}


def test_a_driver_silent_for_driver_quiet_s_is_replaced_by_the_next_source():
    tool = Tool(HOME)
    tool.offer(1, 0, (0.1, 0.0, 0.5), 2.0)
    assert not tool.offer(2, 0, (0.3, 0.0, 0.5), 2.0 + DRIVER_QUIET_S - 0.001)
    assert tool.offer(2, 1, (0.3, 0.0, 0.5), 2.0 + DRIVER_QUIET_S)
    assert (tool.driver, tool.seq, tool.tracked) == (2, 1, (0.3, 0.0, 0.5))
    assert not tool.offer(1, 1, (0.1, 0.0, 0.5), 2.0 + DRIVER_QUIET_S + 0.5), "the new driver's quiet time counts now"


def test_when_the_driver_leaves_the_tool_goes_home():
    tool = Tool(HOME)
    tool.offer(1, 5, (0.1, 0.0, 0.5), 0.0)
    assert not tool.release(2) and tool.driver == 1, "a source that did not drive changes nothing"
    assert tool.release(1)
    assert (tool.driver, tool.seq, tool.tracked) == (None, None, HOME)
    assert not tool.release(1)
    assert tool.offer(2, 0, (0.3, 0.0, 0.5), 0.1), "anyone may drive now"


def test_a_held_position_overrides_the_tracker_and_lands_the_proxy_on_the_surface():
    ground = [Body("ground", Plane((4.0, 4.0)), Pose(), 1000.0)]
    tool = Tool(HOME, proxy_radius=0.0)
    tool.offer(1, 0, (0.0, 0.0, 0.5), 0.0)
    tool.hold((0.2, 0.0, -0.01), ground)
    assert tool.hip == (0.2, 0.0, -0.01) and tool.god.proxy == (0.2, 0.0, 0.0)
    tool.hold(None, ground)
    assert tool.hip == (0.0, 0.0, 0.5)


def test_a_settled_step_is_reused_until_the_bodies_change():
    ground = [Body("ground", Plane((4.0, 4.0)), Pose(), 1000.0)]
    tool = Tool(HOME, proxy_radius=0.0)
    hip = (0.0, 0.0, -0.01)
    first, second = tool.proxy_step(ground, hip), tool.proxy_step(ground, hip)
    assert second.proxy == first.proxy and tool._settled == (hip, second), "a fixed point after two equal steps"
    assert tool.proxy_step(ground, hip) is second
    tool.forget_fixed_point()
    assert tool.proxy_step(ground, hip) is not second
