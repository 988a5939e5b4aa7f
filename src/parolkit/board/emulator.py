"""The emulated PAROL6 control board (stock firmware semantics, byte for byte).

See the package docstring of :mod:`parolkit.board` for the control API in one page and
``docs/board-emulator.md`` for every deliberate difference from the stock firmware.

Time model
----------
The firmware's main loop is free-running.  The emulator runs the same loop body at a fixed
simulated pass rate (``pass_hz``, default 2000 Hz, >= 1000): every pass applies the sticky
command (JOG speed, GO TO P-loop, homing state-machine step), integrates the steppers and
the gripper.  Simulated time comes from one of two clocks:

* ``clock="realtime"``: simulated time follows ``time.monotonic()``.  :meth:`start` runs a
  background thread that keeps the loop caught up; every public accessor also catches up
  first, so what you read is always "now".
* ``clock="virtual"``: time stands still until :meth:`advance` (seconds) is called: fast,
  deterministic tests.

Serial bytes
------------
:meth:`write` takes bytes from the PC, :meth:`read` returns the bytes the board sent.
Incoming bytes are drained like the firmware does (hunt FF FF FF, LEN, collect LEN bytes,
check 01 02), except that a LEN other than 52 is refused (the firmware would read a short
frame at fixed offsets); every accepted frame gets exactly one 60-byte status frame.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from enum import Enum
from typing import TypeVar

from parolkit._native import load as load_native
from parolkit.board.faults import ByteFaultInjector, LinkFaults, faults_from_options
from parolkit.board.gripper import GripperState, SSG48Gripper
from parolkit.board.homing import (
    J5_OFFSET_PNEUMATIC,
    J5_OFFSET_SSG48,
    STANDBY_STEPS,
    HomingPhase,
    HomingSequence,
)
from parolkit.board.steppers import SPEED_CLAMP_STEPS_S, Stepper, clamp_speed
from parolkit.errors import ParolkitValueError
from parolkit.protocol.frames import (
    TIMER_HZ,
    BoardCommand,
    CommandFrame,
    IOBits,
    StatusFrame,
)
from parolkit.protocol.stream import CommandParser, ParserStats
from parolkit.robot import PAROL6, RobotModel
from parolkit.transport.base import LinkLostError

__all__ = ["BoardEmulator", "ClockMode", "EmulatorStats", "Direction"]

_T = TypeVar("_T")

_HOMING_CONTINUES = frozenset(range(256)) - {101, 102, 103, 123, 156}
#: the IO byte's bits as plain ints (the status frame is built every frame)
_IN1, _IN2, _ESTOP = int(IOBits.IN1), int(IOBits.IN2), int(IOBits.ESTOP)
_OUTPUTS = int(IOBits.OUT1 | IOBits.OUT2)


class ClockMode(str, Enum):
    """Where simulated time comes from."""

    REALTIME = "realtime"
    VIRTUAL = "virtual"


class Direction(str, Enum):
    """Which way a link fault applies."""

    TO_BOARD = "to_board"
    FROM_BOARD = "from_board"
    BOTH = "both"


@dataclass(frozen=True)
class EmulatorStats:
    """Counters of the emulated board's serial side."""

    frames_accepted: int
    replies_sent: int
    parser: dict[str, int]
    bytes_dropped_by_faults: int
    bytes_corrupted_by_faults: int


def _check_number(value: object, name: str, lo: float, hi: float, unit: str = "") -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ParolkitValueError(f"{name} must be a number in {lo:g}..{hi:g}{unit}, got {value!r}")
    v = float(value)
    if math.isnan(v) or not lo <= v <= hi:
        raise ParolkitValueError(f"{name} = {value!r} is out of range {lo:g}..{hi:g}{unit}")
    return v


def _check_bool(value: object, name: str) -> bool:
    if isinstance(value, bool):
        return value
    if isinstance(value, int) and value in (0, 1):
        return bool(value)
    raise ParolkitValueError(f"{name} must be a bool (or 0/1), got {value!r}")


def _joint_mask(joints: Iterable[object] | None, name: str) -> int:
    """Joint list (1..6 or "J1".."J6") -> bits J1 = 0x80 .. J6 = 0x04."""
    if joints is None:
        return 0
    if isinstance(joints, (str, int)):
        joints = [joints]
    mask = 0
    for j in joints:
        idx: int | None = None
        if isinstance(j, str) and j.upper().startswith("J") and j[1:].isdigit():
            idx = int(j[1:])
        elif isinstance(j, int) and not isinstance(j, bool):
            idx = j
        if idx is None or not 1 <= idx <= 6:
            raise ParolkitValueError(f"{name}: joint {j!r} is not one of 1..6 / J1..J6")
        mask |= 0x80 >> (idx - 1)
    return mask


def goto_passes(n: int, dt: float, clamp: int, counters: tuple[int, ...], phases: tuple[float, ...],
                targets: tuple[int, ...], feed_forwards: tuple[int, ...],
                ) -> tuple[tuple[int, ...], tuple[float, ...], tuple[int, ...], bool]:
    """``n`` (>= 1) passes of the GO TO law, ``v = int(((target - counter) / 0.01 + v_ff) / 2)``
    clamped to +-``clamp`` (whole steps/s), each joint stepped once a pass (``phase += v x dt``,
    its whole steps move the counter); a joint whose speed comes out 0 stays there (its counter
    no longer changes).  Returns the counters, the sub-step phases, the speeds, and whether
    every joint reached speed 0 within the passes.  The joints do not interact, so each runs
    its passes on its own, in local variables (the same arithmetic, in the same order, as one
    pass of all joints after another).  The reference of the compiled ``_cgoto.passes``."""
    out_c, out_a, out_v = [], [], []
    settled = True
    for c, acc, tgt, vff in zip(counters, phases, targets, feed_forwards):
        v = 0
        for _ in range(n):
            v = int(((tgt - c) / 0.01 + vff) / 2)
            if v > clamp:
                v = clamp
            elif v < -clamp:
                v = -clamp
            if not v:
                break
            acc = acc + v * dt
            k = int(acc)
            acc = acc - k
            c += k
        else:
            settled = False  # still running after the n passes
        out_c.append(c)
        out_a.append(acc)
        out_v.append(v)
    return tuple(out_c), tuple(out_a), tuple(out_v), settled


_cgoto = load_native("parolkit.board._cgoto")
#: the GO TO passes: compiled when built, else the reference
_goto_passes: Callable[[int, float, int, tuple[int, ...], tuple[float, ...], tuple[int, ...], tuple[int, ...]],
                       tuple[tuple[int, ...], tuple[float, ...], tuple[int, ...], bool]] = (
    _cgoto.passes if _cgoto is not None else goto_passes)


class BoardEmulator:
    """An emulated PAROL6 control board running the stock firmware's behaviour.

    Parameters (all keyword-only; bad values raise ``ParolkitValueError`` naming them):

    * ``clock``: ``"realtime"`` (default) or ``"virtual"`` (see :meth:`advance`).
    * ``homing_speedup``: time scale of the homing sequence, 1..1000 (1 = real time).
    * ``pass_hz``: simulated main-loop passes per second, 1000..20000.
    * ``power_up_steps``: physical joint positions at power-up in the post-homing count frame
      (default: the standby pose).  The step counters always start at 0.
    * ``start_homed``: opt-in shortcut: power up as if homing had just finished (counters at
      the standby counts, homed 0xFF).  Not stock behaviour; default False.
    * ``j5_offset_steps``: J5 move after its reference: 8900 (pneumatic, stock) or 8035 (SSG-48).
    * ``gripper_calibration_s``: SSG-48 calibration time, s.
    * ``estop_pressed``, ``in1``, ``in2``: initial inputs.
    * ``seed``: seed of the fault injector's random generator.
    """

    def __init__(
        self,
        *,
        clock: str | ClockMode = ClockMode.REALTIME,
        homing_speedup: float = 1.0,
        pass_hz: int = 2000,
        power_up_steps: Sequence[int] | None = None,
        start_homed: bool = False,
        j5_offset_steps: int = J5_OFFSET_PNEUMATIC,
        gripper_calibration_s: float = 1.0,
        estop_pressed: bool = False,
        in1: bool = False,
        in2: bool = False,
        seed: int | None = None,
        model: RobotModel = PAROL6,
    ) -> None:
        try:
            self.clock = ClockMode(clock)
        except ValueError:
            raise ParolkitValueError(
                f"clock must be 'realtime' or 'virtual', got {clock!r}") from None
        self.homing_speedup = _check_number(homing_speedup, "homing_speedup", 1.0, 1000.0)
        if isinstance(pass_hz, bool) or not isinstance(pass_hz, int) \
                or not 1000 <= pass_hz <= 20000:
            raise ParolkitValueError(f"pass_hz must be an integer in 1000..20000, got {pass_hz!r}")
        self.pass_hz = pass_hz
        self._dt = 1.0 / pass_hz
        if power_up_steps is None:
            phys = list(STANDBY_STEPS)
        else:
            if isinstance(power_up_steps, (str, bytes)) or not hasattr(power_up_steps, "__len__") \
                    or len(power_up_steps) != 6:
                raise ParolkitValueError(
                    f"power_up_steps must be 6 integers (J1..J6, steps), got {power_up_steps!r}")
            phys = []
            for i, v in enumerate(power_up_steps):
                if isinstance(v, bool) or not isinstance(v, int) or not -(1 << 23) <= v < (1 << 23):
                    raise ParolkitValueError(
                        f"power_up_steps[J{i + 1}] must be an integer in -8388608..8388607, got {v!r}")
                phys.append(v)
        if j5_offset_steps not in (J5_OFFSET_PNEUMATIC, J5_OFFSET_SSG48):
            raise ParolkitValueError(
                f"j5_offset_steps must be {J5_OFFSET_PNEUMATIC} (pneumatic) or "
                f"{J5_OFFSET_SSG48} (SSG-48), got {j5_offset_steps!r}")
        self.model = model
        self._lock = threading.RLock()
        self._steppers = [Stepper(p) for p in phys]
        self._homing = HomingSequence(self._steppers, max_speeds_steps_s=model.max_speed_steps_s,
                                      j5_offset_steps=j5_offset_steps)
        self._homed = 0x03
        if _check_bool(start_homed, "start_homed"):
            for st, c in zip(self._steppers, STANDBY_STEPS):
                st.set_counter(c)
            self._homed = 0xFF
        self._enabled = True
        self._command = int(BoardCommand.IDLE)
        self._targets: tuple[int, ...] = (0, 0, 0, 0, 0, 0)
        self._ff: tuple[int, ...] = (0, 0, 0, 0, 0, 0)
        self._outputs = 0
        self._estop = _check_bool(estop_pressed, "estop_pressed")
        self._in1 = _check_bool(in1, "in1")
        self._in2 = _check_bool(in2, "in2")
        self._temp_mask = 0
        self._pos_mask = 0
        self._gripper = SSG48Gripper(calibration_s=_check_number(
            gripper_calibration_s, "gripper_calibration_s", 0.0, 60.0, " s"))
        self._gripper_id = 0
        self._parser = CommandParser()
        self._inbound = ByteFaultInjector(seed=seed)
        self._outbound = ByteFaultInjector(seed=None if seed is None else seed + 1)
        self._plugged = True
        self._link_listeners: list[Callable[[bool], None]] = []
        #: called with (frame as executed, true reply) for every frame taken from the link
        self._exchange_listeners: list[Callable[[CommandFrame, StatusFrame], None]] = []
        self._frames = 0
        self._replies = 0
        #: (counters, speeds, homed) as copied by the last loop pass
        self._telemetry: tuple[tuple[int, ...], tuple[int, ...], int] = (
            tuple(st.counter for st in self._steppers), (0,) * 6, self._homed)
        # time
        self._t = 0.0  # simulated seconds since power-up
        self._last_frame_t = 0.0
        self._wall0 = time.monotonic()
        self._telling = False  # exchange listeners run (time_s does not catch up meanwhile)
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()

    # =======================================================================================
    # clock
    # =======================================================================================
    @property
    def time_s(self) -> float:
        """Simulated seconds since power-up.  In an exchange listener: the time of that
        exchange (the board does not run on while it tells its listeners)."""
        with self._lock:
            if not self._telling:
                self._catch_up()
            return self._t

    def advance(self, seconds: float) -> None:
        """Virtual clock only: run the board loop for ``seconds`` (0..3600) of simulated time."""
        s = _check_number(seconds, "seconds", 0.0, 3600.0, " s")
        if self.clock is not ClockMode.VIRTUAL:
            raise ParolkitValueError(
                "advance() needs clock='virtual'; this emulator follows the real-time clock")
        with self._lock:
            self._run_until(self._t + s)

    def start(self) -> None:
        """Real-time clock: start the background loop thread (idempotent)."""
        if self.clock is not ClockMode.REALTIME:
            raise ParolkitValueError("start() needs clock='realtime' (a virtual clock is advanced "
                                     "with advance())")
        if self._thread is not None and self._thread.is_alive():
            return
        self._stop.clear()
        self._thread = threading.Thread(target=self._thread_main, name="parolkit-board-loop",
                                        daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stop the background loop thread (the board state stays as it is)."""
        self._stop.set()
        t = self._thread
        if t is not None and t is not threading.current_thread():
            t.join(timeout=2.0)
        self._thread = None

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def _thread_main(self) -> None:
        while not self._stop.wait(0.005):
            with self._lock:
                self._catch_up()

    def _catch_up(self) -> None:
        if self.clock is ClockMode.REALTIME:
            self._run_until(time.monotonic() - self._wall0)

    def _run_until(self, t_end: float) -> None:
        n = int((t_end - self._t) * self.pass_hz + 1e-9)
        if n > 0:
            self._passes(n)

    # =======================================================================================
    # the main loop body
    # =======================================================================================
    def _passes(self, n: int) -> None:
        """Run ``n`` loop passes, then copy counters, speeds and homed into the telemetry."""
        self._run_passes(n)
        sts = self._steppers
        self._telemetry = (tuple([st.counter for st in sts]), tuple([st.speed for st in sts]), self._homed)

    def _run_passes(self, n: int) -> None:
        dt = self._dt
        g = self._gripper
        if self._homing.active:
            if self._enabled and self._command in _HOMING_CONTINUES:
                dth = dt * self.homing_speedup
                for i in range(n):
                    bits = self._homing.step(dth)
                    if bits:
                        self._homed = 0xFF if bits == 0xFF else self._homed | bits
                    if g.busy:
                        g.advance(dt)
                    if not self._homing.active:
                        self._t += (i + 1) * dt
                        self._run_passes(n - i - 1)
                        return
            elif g.busy:
                for _ in range(n):
                    g.advance(dt)
            self._t += n * dt
            return
        cmd = self._command
        if self._enabled and cmd == BoardCommand.GOTO:
            self._goto_passes(n, dt)
            for _ in range(n):  # (advance does nothing once the jaws are idle)
                if not g.busy:
                    break
                g.advance(dt)
        else:
            if self._enabled and cmd == BoardCommand.JOG:
                span = n * dt  # constant speeds: n passes integrate exactly like one span
                for st in self._steppers:
                    if st.speed:
                        st.run(st.speed, span)
            if g.busy:
                for _ in range(n):
                    g.advance(dt)
        self._t += n * dt

    def _goto_passes(self, n: int, dt: float) -> None:
        """``n`` passes of the GO TO law on every joint (:func:`goto_passes`, compiled when
        built); when every joint's speed reached 0 within them the board stood still from that
        pass on and the sub-step phases are forgotten."""
        if n <= 0:
            return
        sts = self._steppers
        counters, phases, speeds, settled = _goto_passes(
            n, dt, SPEED_CLAMP_STEPS_S, tuple(st.counter for st in sts), tuple(st._acc for st in sts),
            self._targets, self._ff)
        for st, c, acc, v in zip(sts, counters, phases, speeds):
            st.counter = c
            st._acc = 0.0 if settled else acc
            st.speed = v

    # =======================================================================================
    # frames
    # =======================================================================================
    def process_frame(self, frame: CommandFrame) -> StatusFrame:
        """Accept one decoded command frame (as if it arrived now) and return the reply.

        This bypasses the serial link (no faults, works while unplugged); :meth:`write` /
        :meth:`read` are the byte-level path.
        """
        if not isinstance(frame, CommandFrame):
            raise ParolkitValueError(f"frame must be a CommandFrame, got {type(frame).__name__}")
        with self._lock:
            self._catch_up()
            return self._accept(frame)

    def _accept(self, frame: CommandFrame) -> StatusFrame:
        now = self._t
        timing = int(round((now - self._last_frame_t) * TIMER_HZ)) & 0xFFFF
        self._last_frame_t = now
        cmd = int(frame.command)
        self._command = cmd
        self._frames += 1
        sts = self._steppers
        if cmd in (BoardCommand.ENABLE, BoardCommand.DISABLE, BoardCommand.CLEAR_ERROR):
            # stop homing (and reset its state machine); these commands generate no steps
            self._homing.abort()
            if cmd == BoardCommand.ENABLE:
                self._enabled = True
            elif cmd == BoardCommand.DISABLE:
                self._enabled = False
            for st in sts:
                st.speed = 0
        elif not self._enabled:
            pass  # 100 / 123 / 156 / idle do nothing while disabled
        elif cmd == BoardCommand.HOME:
            self._homing.start()
            self._homed = 0x03
        elif cmd == BoardCommand.JOG:
            self._homing.abort()
            for st, v in zip(sts, frame.speeds):
                st.speed = clamp_speed(v)
        elif cmd == BoardCommand.GOTO:
            self._homing.abort()
            self._targets = frame.positions
            self._ff = frame.speeds
            for st, tgt, vff in zip(sts, self._targets, self._ff):
                st.speed = clamp_speed(((tgt - st.counter) / 0.01 + vff) / 2)
        elif not self._homing.active:
            # IDLE and unknown codes: speeds set from the frame, no steps generated
            for st, v in zip(sts, frame.speeds):
                st.speed = clamp_speed(v)
                st.stop_phase()
        if not self._enabled:
            for st in sts:
                st.speed = 0
                st.stop_phase()
        # IO: outputs follow the frame, inputs are sampled now
        self._outputs = frame.io & _OUTPUTS
        self._gripper_id = frame.gripper_id
        self._gripper.on_frame(frame.gripper_position, frame.gripper_speed,
                               frame.gripper_current, frame.gripper_command, frame.gripper_mode)
        return self._status(timing=timing, xtr=cmd)

    def _io_byte(self) -> int:
        return (
            (_IN1 if self._in1 else 0)
            | (_IN2 if self._in2 else 0)
            | int(self._outputs)
            | (0 if self._estop else _ESTOP)
            | 0x07
        )

    def _status(self, *, timing: int, xtr: int) -> StatusFrame:
        # like the firmware, the reply carries the telemetry copied by the last loop pass:
        # the frame being answered takes effect from the next pass on
        positions, speeds, homed = self._telemetry
        g = self._gripper
        return StatusFrame(
            positions=positions,
            speeds=speeds,
            homed=homed,
            io=int(self._io_byte()),
            temperature_error=self._temp_mask | 0x03,
            position_error=self._pos_mask | 0x03,
            timing=timing,
            timeout_error=100,
            xtr=xtr,
            gripper_id=self._gripper_id,
            gripper_position=int(round(g.position)),
            gripper_speed=1,
            gripper_current=g.current_ma,
            gripper_status=g.status_byte(),
            object_detection=1,
        )

    def status_frame(self) -> StatusFrame:
        """The telemetry of the last loop pass as a status frame (``timing`` 0, ``xtr`` = last
        command).  :attr:`positions` / :attr:`speeds` are the live values."""
        with self._lock:
            self._catch_up()
            return self._status(timing=0, xtr=self._command)

    # =======================================================================================
    # serial bytes (the link)
    # =======================================================================================
    def write(self, data: bytes) -> None:
        """Bytes from the PC.  Raises ``LinkLostError`` while unplugged."""
        if not isinstance(data, (bytes, bytearray, memoryview)):
            raise ParolkitValueError(f"data must be bytes, got {type(data).__name__}")
        with self._lock:
            if not self._plugged:
                raise LinkLostError("emulated board is unplugged (call replug())")
            self._catch_up()
            self._inbound.push(bytes(data), self._t)
            self._drain_inbound()

    def read(self) -> bytes:
        """Every byte the board has sent and not yet read.  Raises ``LinkLostError`` while unplugged."""
        with self._lock:
            if not self._plugged:
                raise LinkLostError("emulated board is unplugged (call replug())")
            self._catch_up()
            self._drain_inbound()
            return self._outbound.pop(self._t)

    def next_output_due(self) -> float | None:
        """Simulated time at which delayed bytes become readable (None if none are held)."""
        with self._lock:
            return self._outbound.next_due

    def _drain_inbound(self) -> None:
        data = self._inbound.pop(self._t)
        if not data:
            return
        if self._inbound.faults.silent:
            return  # the board has stopped answering: bytes vanish
        for frame in self._parser.iter_feed(data):
            reply = self._accept(frame)
            self._replies += 1
            self._telling = True
            try:
                for cb in self._exchange_listeners:
                    cb(frame, reply)  # before the link's faults touch the reply
            finally:
                self._telling = False
            self._outbound.push(reply.encode(), self._t)

    # ---- link faults -------------------------------------------------------------------------
    def set_faults(self, faults: LinkFaults | None = None, *,
                   direction: str | Direction = Direction.BOTH, **kw: object) -> None:
        """Switch link faults on (or off with ``LinkFaults()``).

        Either pass a :class:`LinkFaults` or its fields as keywords (``drop_rate``,
        ``corrupt_rate``, ``delay_s``, ``silent``).  ``direction``: ``"to_board"``,
        ``"from_board"`` or ``"both"`` (``silent`` always concerns the board's receiver).
        """
        if faults is None:
            faults = faults_from_options(kw)
        elif kw:
            raise ParolkitValueError("pass either a LinkFaults or keyword fields, not both")
        if not isinstance(faults, LinkFaults):
            raise ParolkitValueError(f"faults must be a LinkFaults, got {type(faults).__name__}")
        try:
            d = Direction(direction)
        except ValueError:
            raise ParolkitValueError(
                f"direction must be 'to_board', 'from_board' or 'both', got {direction!r}") from None
        with self._lock:
            if d in (Direction.TO_BOARD, Direction.BOTH):
                self._inbound.set_faults(faults)
            if d in (Direction.FROM_BOARD, Direction.BOTH):
                out = LinkFaults(drop_rate=faults.drop_rate, corrupt_rate=faults.corrupt_rate,
                                 delay_s=faults.delay_s)
                self._outbound.set_faults(out)
                if d is Direction.FROM_BOARD:
                    self._inbound.set_faults(LinkFaults(silent=faults.silent))

    def clear_faults(self) -> None:
        """A perfect link again."""
        self.set_faults(LinkFaults())

    @property
    def faults(self) -> tuple[LinkFaults, LinkFaults]:
        """(to-board faults, from-board faults)."""
        return self._inbound.faults, self._outbound.faults

    def unplug(self) -> None:
        """The USB link disappears (the board keeps running its last command)."""
        with self._lock:
            if not self._plugged:
                return
            self._catch_up()
            self._plugged = False
            self._parser.reset()
            self._inbound.clear()
            self._outbound.clear()
            listeners = list(self._link_listeners)
        for cb in listeners:
            cb(False)

    def replug(self) -> None:
        """The link comes back (a fresh connection: no stale bytes)."""
        with self._lock:
            if self._plugged:
                return
            self._catch_up()
            self._plugged = True
            listeners = list(self._link_listeners)
        for cb in listeners:
            cb(True)

    @property
    def plugged(self) -> bool:
        return self._plugged

    def add_link_listener(self, callback: Callable[[bool], None]) -> None:
        """``callback(plugged)`` runs after every unplug/replug (used by the pty server)."""
        if not callable(callback):
            raise ParolkitValueError("callback must be callable")
        self._link_listeners.append(callback)

    def remove_link_listener(self, callback: Callable[[bool], None]) -> None:
        if callback in self._link_listeners:
            self._link_listeners.remove(callback)

    def add_exchange_listener(self, callback: Callable[[CommandFrame, StatusFrame], None]) -> None:
        """``callback(frame, reply)`` runs for every frame the board takes from the link (as
        it executes it, after any injected fault) with the status frame it answers (before any
        injected fault), under the board's lock: keep it short (used by the pty server's
        exchange log)."""
        if not callable(callback):
            raise ParolkitValueError("callback must be callable")
        self._exchange_listeners.append(callback)

    def remove_exchange_listener(self, callback: Callable[[CommandFrame, StatusFrame], None]) -> None:
        if callback in self._exchange_listeners:
            self._exchange_listeners.remove(callback)

    # =======================================================================================
    # inputs, objects, error injection
    # =======================================================================================
    def set_estop(self, pressed: bool) -> None:
        """Press (True) or release (False) the hardware E-stop.  The firmware only reports it."""
        v = _check_bool(pressed, "pressed")
        with self._lock:
            self._estop = v

    def set_input(self, number: int, value: bool) -> None:
        """Set digital input IN1 (``number=1``) or IN2 (``number=2``)."""
        if isinstance(number, bool) or number not in (1, 2):
            raise ParolkitValueError(f"number must be 1 (IN1) or 2 (IN2), got {number!r}")
        v = _check_bool(value, "value")
        with self._lock:
            if number == 1:
                self._in1 = v
            else:
                self._in2 = v

    def place_object(self, width_mm: float | None) -> None:
        """Put an object ``width_mm`` wide (0 < w < 48) between the gripper jaws (None removes it)."""
        with self._lock:
            self._catch_up()
            self._gripper.place_object(width_mm)

    def remove_object(self) -> None:
        self.place_object(None)

    def inject_errors(self, *, temperature: Iterable[object] | None = None,
                      position: Iterable[object] | None = None) -> None:
        """Opt-in: report temperature / position error bits for the given joints (1..6 or "J1").

        Replaces the previous injection; the constant 0x03 bits are always reported.
        """
        t = _joint_mask(temperature, "temperature")
        p = _joint_mask(position, "position")
        with self._lock:
            self._temp_mask = t
            self._pos_mask = p

    def clear_errors(self) -> None:
        """Back to the stock constant error bytes (0x03, 0x03)."""
        self.inject_errors()

    def power_cycle(self) -> None:
        """Power-up state again: counters 0 (joints stay where they are), homed 0x03, enabled."""
        with self._lock:
            self._catch_up()
            self._homing.abort()
            for st in self._steppers:
                st.set_counter(0)
                st.speed = 0
            self._homed = 0x03
            self._enabled = True
            self._command = int(BoardCommand.IDLE)
            self._outputs = 0
            self._parser.reset()
            self._telemetry = (tuple(st.counter for st in self._steppers), (0,) * 6, self._homed)

    # =======================================================================================
    # read-only views
    # =======================================================================================
    def _view(self, fn: Callable[[], _T]) -> _T:
        with self._lock:
            self._catch_up()
            return fn()

    @property
    def positions(self) -> tuple[int, ...]:
        """Step counters J1..J6 (what the board reports), steps."""
        return self._view(lambda: tuple(st.counter for st in self._steppers))

    @property
    def physical_positions(self) -> tuple[int, ...]:
        """Where the joints really are, post-homing count frame, steps."""
        return self._view(lambda: tuple(st.physical for st in self._steppers))

    @property
    def speeds(self) -> tuple[int, ...]:
        """Last speed set on each stepper, steps/s."""
        return self._view(lambda: tuple(st.speed for st in self._steppers))

    @property
    def homed(self) -> int:
        """Homed byte (0x03 at power-up, 0xFF when homed)."""
        return self._view(lambda: self._homed)

    @property
    def homing_active(self) -> bool:
        return self._view(lambda: self._homing.active)

    @property
    def homing_phase(self) -> HomingPhase:
        return self._view(lambda: self._homing.phase)

    @property
    def enabled(self) -> bool:
        return self._view(lambda: self._enabled)

    @property
    def command(self) -> int:
        """The sticky last accepted command code."""
        return self._view(lambda: self._command)

    @property
    def outputs(self) -> tuple[bool, bool]:
        """(OUT1, OUT2) as driven by the last accepted frame."""
        return self._view(lambda: (bool(self._outputs & IOBits.OUT1),
                                   bool(self._outputs & IOBits.OUT2)))

    @property
    def inputs(self) -> tuple[bool, bool]:
        return self._view(lambda: (self._in1, self._in2))

    @property
    def estop_pressed(self) -> bool:
        return self._view(lambda: self._estop)

    @property
    def gripper(self) -> GripperState:
        return self._view(self._gripper.state)

    @property
    def error_injection(self) -> tuple[int, int]:
        """(temperature bits, position bits) injected, J1 = 0x80."""
        return self._view(lambda: (self._temp_mask, self._pos_mask))

    @property
    def stats(self) -> EmulatorStats:
        def make() -> EmulatorStats:
            ps: ParserStats = self._parser.stats
            return EmulatorStats(
                frames_accepted=self._frames,
                replies_sent=self._replies,
                parser=ps.as_dict(),
                bytes_dropped_by_faults=self._inbound.counters.dropped
                + self._outbound.counters.dropped,
                bytes_corrupted_by_faults=self._inbound.counters.corrupted
                + self._outbound.counters.corrupted,
            )
        return self._view(make)

    def describe(self) -> dict[str, object]:
        """Everything in one JSON-friendly dict (for the control channel's ``status``)."""
        with self._lock:
            self._catch_up()
            g = self._gripper.state()
            return {
                "time_s": round(self._t, 4),
                "plugged": self._plugged,
                "enabled": self._enabled,
                "command": self._command,
                "positions": [st.counter for st in self._steppers],
                "speeds": [st.speed for st in self._steppers],
                "homed": self._homed,
                "homing": self._homing.phase.value if self._homing.active else None,
                "io": self._io_byte(),
                "estop_pressed": self._estop,
                "inputs": [self._in1, self._in2],
                "outputs": [bool(self._outputs & IOBits.OUT1), bool(self._outputs & IOBits.OUT2)],
                "errors": {"temperature": self._temp_mask, "position": self._pos_mask},
                "gripper": {"position": g.position, "current_ma": g.current_ma,
                            "status": g.status.to_byte(), "object_mm": g.object_width_mm},
                "frames_accepted": self._frames,
                "faults": {"to_board": vars_of(self._inbound.faults),
                           "from_board": vars_of(self._outbound.faults)},
            }

    def __enter__(self) -> BoardEmulator:
        if self.clock is ClockMode.REALTIME:
            self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def vars_of(f: LinkFaults) -> dict[str, object]:
    return {"drop_rate": f.drop_rate, "corrupt_rate": f.corrupt_rate, "delay_s": f.delay_s,
            "silent": f.silent}
