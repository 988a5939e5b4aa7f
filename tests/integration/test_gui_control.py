"""The commander's side of the control lease against a real controller process over real UDP:
its link (:class:`~parolkit.gui.link.ControllerLink`) and :class:`~parolkit.gui.lease_watch.ControlWatch`
(no browser: the page only shows ``watch.view``)."""

from __future__ import annotations

import asyncio
import time

from tests.conftest import start_controller

from parolkit.client.robot import Robot
from parolkit.gui.lease_watch import ControlWatch, Holder, local_host_for
from parolkit.gui.link import ControllerLink

SECRET = "s3cret-words"


async def until(cond, timeout: float = 5.0, what: str = "condition"):
    deadline = time.monotonic() + timeout
    while not cond():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        await asyncio.sleep(0.02)


def test_with_a_controller_secret_the_commander_takes_control_with_it_and_hands_it_over(tmp_path):
    cfg = tmp_path / "parolkit.toml"
    cfg.write_text(f'[controller]\nsecret = "{SECRET}"\nlease_timeout_s = 2.0\n')
    cp = start_controller(["--config", str(cfg)], log_dir=tmp_path)

    async def main():
        link = ControllerLink("127.0.0.1", cp.port, cp.ack_port, every_n_ticks=10)
        lines = lambda: [e.text for e in link.log.tail(200)]  # noqa: E731
        await link.start()
        watch = ControlWatch(link.robot, link.send, local_host=local_host_for("127.0.0.1"), secret=SECRET,
                             poll_s=0.2)
        watch.start()
        try:
            await until(lambda: watch.view.holder is Holder.FREE, what="the lease free")
            assert "secret required" in watch.view.text
            # a command alone does not take the lease when the controller has a secret ...
            link.send("ENABLE", label="bare Enable")
            await until(lambda: any(m.startswith("bare Enable failed") for m in lines()), what="refusal")
            assert any("shared secret" in m for m in lines())
            # ... so the commander takes it with the secret first (once, not per command)
            watch.ensure()
            link.send("ENABLE", label="Enable")
            watch.ensure()  # not confirmed yet: no second TAKE
            await until(lambda: "Enable completed: enabled" in lines(), what="Enable accepted")
            await until(lambda: watch.mine, what="the badge: ours")
            assert watch.view.text == "You control the robot"
            assert sum(m.startswith("Take control") for m in lines()) == 0  # quiet: only failures are logged
            # the program runner (another client) gets it after the hand-over
            await watch.hand_over()
            runner = await asyncio.to_thread(Robot, "127.0.0.1", cp.port, ack_port=0, timeout=2.0)
            try:
                watch.runner_port = lambda: runner.ack_port
                await asyncio.to_thread(runner.take_control, secret=SECRET)
                await until(lambda: watch.view.holder is Holder.RUNNER, what="the badge: our program")
                await asyncio.to_thread(runner.delay, 0.1)
            finally:
                await asyncio.to_thread(runner.close)  # gives it back
            await until(lambda: watch.view.holder is Holder.FREE, what="free after the program")
            # the operator's Take control, with the secret
            watch.take_over()
            await until(lambda: "Take control completed: control taken by 127.0.0.1:"
                        f"{link.robot.ack_port}" in lines(), what="taken")
            await until(lambda: watch.mine, what="ours again")
            # idle, the commander lets it lapse (it sends nothing to keep it)
            await until(lambda: watch.view.holder is Holder.FREE, timeout=6.0, what="the lease lapsing")
        finally:
            await watch.stop()
            await link.close()

    try:
        asyncio.run(main())
    finally:
        cp.stop()
    assert SECRET not in cp.log()


def test_a_cartesian_jog_limited_at_the_wrist_singularity_says_so_in_the_log_once(tmp_path):
    """Holding X+ from the standby pose (J5 = 0) turns J4/J6 while the TCP moves: the jog's
    EXECUTING ack says so, and the commander showed nothing (issue 14).  Its jog stream is
    quiet (only failures logged), so the note is logged from the EXECUTING ack, once for the
    whole stream of updates."""
    cp = start_controller([], log_dir=tmp_path)

    async def main():
        link = ControllerLink("127.0.0.1", cp.port, cp.ack_port, every_n_ticks=10)
        lines = lambda: [e.text for e in link.log.tail(200)]  # noqa: E731
        await link.start()
        try:
            await until(lambda: link.status is not None, what="the first status")
            for _ in range(8):  # the commander's hold-to-jog: an update every 100 ms
                link.send("CARTJOG|WRF|X+|50|0.3", label="Jog X+", quiet=True)
                await asyncio.sleep(0.1)
            await until(lambda: any("wrist singular area" in m for m in lines()), timeout=10,
                        what="the singular-area note")
            notes = [m for m in lines() if "wrist singular area" in m]
            assert len(notes) == 1 and notes[0].startswith("Jog X+: "), notes
        finally:
            await link.close()

    try:
        asyncio.run(main())
    finally:
        cp.stop()
