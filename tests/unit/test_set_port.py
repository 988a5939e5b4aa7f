"""SET_PORT in the controller core, tick by tick (the real core and driver on the emulator's
link, :class:`tests.unit.test_controller_core.Rig`): what a command sent with or right after it
gets.  The switch to a real second board is ``tests/integration/test_controller_pty.py``."""

from __future__ import annotations

from tests.unit.test_controller_core import Rig

from parolkit.protocol.commands import AckStatus


def _details(rig: Rig, cid: str) -> list[str]:
    return [d for c, _, d in rig.acks if c == cid]


def test_a_move_that_reaches_the_tick_of_set_port_is_refused_not_queued_and_then_cancelled():
    """SET_PORT and a MOVEJOINT sent back to back reach one tick: the move was QUEUED after the
    switch had been decided, then CANCELLED by it ("board link lost: switching to port ..."),
    and the deliberate switch latched a link-loss error.  Now the move is refused at once (its
    board is not known yet: it must never run on it unseen), SET_PORT is EXECUTING until the
    board there answers, and no error is latched."""
    rig = Rig()
    try:
        rig.send("aaaa0001|SET_PORT|/dev/ttyACM7")
        rig.send("aaaa0002|MOVEJOINT|80|-90|180|0|0|180|2|None")
        rig.step()
        assert rig.statuses("aaaa0001") == [AckStatus.EXECUTING], rig.acks
        assert rig.statuses("aaaa0002") == [AckStatus.FAILED], rig.acks
        assert "switching to /dev/ttyACM7" in _details(rig, "aaaa0002")[0]
        assert rig.outputs[-1].port_request == "/dev/ttyACM7"
        assert not rig.core.link_up and not rig.loop.link_up
        assert rig.core.safety.error is None
        assert rig.core.counters.link_losses == 0
        # a SET_PORT still under way when the controller stops gets its terminal ack
        acks = rig.loop.take_acks()
        assert [(a.command_id, a.status) for a in acks] == [("aaaa0001", AckStatus.CANCELLED)]
    finally:
        rig.close()


def test_set_port_while_a_move_runs_is_refused_and_the_link_stays():
    rig = Rig()
    try:
        rig.send("aaaa0001|MOVEJOINT|80|-90|180|0|0|180|2|None")
        rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0001"))
        rig.send("aaaa0002|SET_PORT|/dev/ttyACM7")
        rig.tick()
        assert rig.statuses("aaaa0002") == [AckStatus.FAILED], rig.acks
        assert rig.outputs[-1].port_request is None and rig.core.link_up
        rig.run_until(lambda: rig.terminal("aaaa0001") is not None)
        assert rig.terminal("aaaa0001") is AckStatus.COMPLETED
    finally:
        rig.close()
