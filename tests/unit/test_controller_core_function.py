"""The controller core is a function of its inputs (issue 23, item 1).

* It runs with no transport, thread or clock: a list of TickInputs (recorded once from a run
  against the board emulator, then replayed into fresh cores) gives the same TickOutputs every
  run, frame for frame, ack for ack, status for status.
* A static check: the core and every parolkit module it imports use no socket, threading, time,
  serial, subprocess or transport module (it could not do I/O, start threads or read a clock
  if it wanted to).
"""

from __future__ import annotations

import ast
import importlib.util
from pathlib import Path

from tests.unit.test_controller_core import RATE, Rig

from parolkit.controller.core import ControllerCore, TickInput, TickOutput
from parolkit.protocol.commands import AckStatus
from parolkit.robot import PAROL6

SRC = Path(importlib.util.find_spec("parolkit").origin).parent  # type: ignore[arg-type]
FORBIDDEN = {"socket", "threading", "time", "serial", "subprocess", "select", "selectors", "asyncio",
             "concurrent", "multiprocessing", "signal", "parolkit.transport", "parolkit.board"}


def _module_file(name: str) -> Path | None:
    rel = Path(*name.split(".")[1:])
    for cand in (SRC / rel.with_suffix(".py"), SRC / rel / "__init__.py"):
        if cand.exists():
            return cand
    return None


def _imports(path: Path) -> set[str]:
    """Modules ``path`` imports at module level or inside functions (any import statement)."""
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module)
            out.update(f"{node.module}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "import_module" and node.args:
            arg = node.args[0]
            if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                out.add(arg.value)
    return out


def _closure(root: str) -> dict[str, set[str]]:
    """Every parolkit module ``root`` reaches by its imports (the lazily imported planners of
    ``planning.plan`` and the kinematics of a snapshot's pose are not part of the core's tick:
    they are followed all the same) -> what it imports."""
    seen: dict[str, set[str]] = {}
    todo = [root]
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        path = _module_file(name)
        if path is None:
            continue
        imps = _imports(path)
        seen[name] = imps
        todo += [m for m in imps if m.startswith("parolkit.") and _module_file(m) is not None]
    return seen


def test_the_core_imports_no_socket_thread_clock_serial_or_transport_module():
    closure = _closure("parolkit.controller.core")
    controller = {m for m in closure if m.startswith("parolkit.controller.")}
    # (the closure is the core's own: the driver, the server, the supervisor are not in it)
    assert "parolkit.controller.core" in controller and "parolkit.controller.guard" in controller
    assert not controller & {"parolkit.controller.driver", "parolkit.controller.server",
                             "parolkit.controller.supervisor", "parolkit.controller.app",
                             "parolkit.controller.inbox"}, sorted(controller)
    bad = {m: sorted(i for i in imps if i in FORBIDDEN or any(i.startswith(f + ".") for f in FORBIDDEN))
           for m, imps in closure.items() if m.startswith("parolkit.controller.")}
    assert not {m: v for m, v in bad.items() if v}, bad


def _record() -> tuple[list[TickInput], list[TickOutput]]:
    """A run against the board emulator (lockstep, plans inline): moves, a jog, a Cartesian
    move, outputs, a delay, a STOP mid-move, an E-stop and its release; every TickInput the
    driver gave the core and every TickOutput it got back."""
    inputs: list[TickInput] = []
    outputs: list[TickOutput] = []
    update = ControllerCore.update

    def recording(self: ControllerCore, inp: TickInput) -> TickOutput:
        out = update(self, inp)
        inputs.append(inp)
        outputs.append(out)
        return out

    ControllerCore.update = recording  # type: ignore[method-assign]  # from the very first tick
    try:
        rig = Rig(lockstep=True)
    finally:
        ControllerCore.update = update  # type: ignore[method-assign]
    rig.core.update = lambda inp: recording(rig.core, inp)  # type: ignore[method-assign]
    try:
        for text in ("aaaa0001|MOVEJOINT|80|-85|170|5|5|170|1|None", "aaaa0002|PNEUMATICGRIPPER|open|1",
                     "aaaa0003|DELAY|0.05", "aaaa0004|JOG|0|40|0.3|None",
                     "aaaa0005|MOVECARTRELTRF|0|0|-20|0|0|0|1|None"):
            rig.send(text)
        rig.run_until(lambda: rig.terminal("aaaa0005") is not None)
        rig.send("aaaa0006|MOVEJOINT|60|-90|180|0|0|180|2|None")
        rig.run_until(lambda: AckStatus.EXECUTING in rig.statuses("aaaa0006"))
        rig.tick(20)
        rig.send("aaaa0007|STOP")
        rig.tick(5)
        rig.send("aaaa0008|ESTOP")
        rig.tick(5)
        rig.send("aaaa0009|ENABLE")
        rig.tick(5)
    finally:
        rig.close()
    assert rig.terminal("aaaa0005") is AckStatus.COMPLETED and rig.terminal("aaaa0006") is AckStatus.CANCELLED
    return inputs, outputs


def _essence(out: TickOutput) -> tuple:
    """What a TickOutput says (the snapshot through its replies: plain data)."""
    snap = out.snapshot
    return (out.frame, out.acks, out.result, out.port_request,
            tuple((r.key, r.command, r.start_deg) for r in out.plan_requests),
            snap.reply("GET_STATUS_JSON"), snap.reply("GET_STATUS"), snap.reply_queue("127.0.0.1:1"))


def _fresh_core() -> ControllerCore:
    return ControllerCore(model=PAROL6, rate_hz=RATE, queue_size=16, watchdog_s=0.02, homing_speedup=200,
                          link_timeout_ticks=3, link_hold_frames=2, lockstep=True)


def test_a_scripted_list_of_tick_inputs_gives_the_same_tick_outputs_every_run():
    inputs, recorded = _record()
    assert len(inputs) > 250
    assert sum(1 for o in recorded if o.frame is not None and o.frame.command == 156) > 150
    want = [_essence(o) for o in recorded]
    for _ in range(2):  # no transport, no thread, no clock: only the inputs
        core = _fresh_core()
        got = [_essence(core.update(inp)) for inp in inputs]
        assert got == want
