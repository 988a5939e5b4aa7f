"""A :class:`SafetyGuard` in front of a real :class:`BoardEmulator` on a virtual clock, as the
control loop drives them: check the frame (against the link record), write what the guard lets
through, record it, take the board's reply (trusted: the emulator does not lie), let board time
run until the next frame.

While the board time runs, the steppers' speeds are read every firmware pass (0.5 ms at the
emulator's 2000 passes/s), so :attr:`GuardedBoard.peak_pass_speed` is the fastest any stepper
actually ran, not only what the status frames report (the firmware copies the speed of the
pass BEFORE the frame it answers: the end of the previous period, never the start)."""

from __future__ import annotations

from dataclasses import dataclass, field

from parolkit.board import BoardEmulator
from parolkit.controller.guard import GuardResult, SafetyGuard
from parolkit.controller.integrity import StatusIntegrity
from parolkit.controller.link import LinkHistory
from parolkit.protocol.frames import BoardCommand, CommandFrame, StatusFrame
from parolkit.robot import PAROL6, RobotModel

RATE = 100.0
PERIOD = 1.0 / RATE
VMAX = tuple(float(v) for v in PAROL6.max_speed_steps_s)


@dataclass
class Sent:
    """One tick: the frame asked, the guard's result, the board's speeds right after it took
    the frame (what the steppers start the period at) and the fastest pass until the next."""

    asked: CommandFrame
    result: GuardResult
    #: the board's reply (its position as the frame arrived, the speeds of the pass before)
    reply: StatusFrame
    start_speeds: tuple[int, ...]
    #: board time until the next frame, s
    wait: float
    peak_speeds: tuple[int, ...] = (0, 0, 0, 0, 0, 0)


@dataclass
class GuardedBoard:
    homed: bool = True
    estop: bool = False
    model: RobotModel = PAROL6
    emu: BoardEmulator = field(init=False)
    guard: SafetyGuard = field(init=False)
    link: LinkHistory = field(init=False)
    #: the integrity check, for what it says of homing (the bench trusts every reply: the
    #: emulator does not lie)
    integrity: StatusIntegrity = field(init=False)
    status: StatusFrame | None = None
    now: float = 0.0
    #: read the steppers at every firmware pass (False: only as each frame arrives; a GO TO
    #: decays and a JOG is constant within the period, so the start is the fastest anyway)
    every_pass: bool = True
    log: list[Sent] = field(default_factory=list)
    #: replies on their way: (read time, frame number answered, status)
    _pending: list[tuple[float, int, StatusFrame]] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.emu = BoardEmulator(clock="virtual", start_homed=self.homed, homing_speedup=200, model=self.model)
        self.guard = SafetyGuard(self.model, RATE)
        self.link = LinkHistory()
        self.integrity = StatusIntegrity(self.model, RATE, homing_speedup=200)
        self.status = self.emu.status_frame()
        self.link.trust(0, self.status, self.now)

    def _deliver(self) -> None:
        """Read every reply due by now, in order (trusted: the emulator does not lie)."""
        while self._pending and self._pending[0][0] <= self.now + 1e-12:
            t, n, st = self._pending.pop(0)
            self.status = st
            self.integrity.accept(st, t, 0, n)
            self.link.trust(self.link.earliest(st), st, t)
            self.link.homing = self.integrity.homing

    @property
    def positions(self) -> tuple[int, ...]:
        return self.emu.positions

    def send(self, frame: CommandFrame, wait: float = PERIOD, *, reply: bool = True,
             reply_delay: float = 0.0) -> GuardResult:
        """One tick: guard ``frame``, write the result, run the board ``wait`` s.  With
        ``reply=False`` the board's reply is lost (the guard keeps the older status); with
        ``reply_delay`` it is read that long after the board sent it (before the first frame
        written at or after that time)."""
        self._deliver()
        res = self.guard.check(frame, self.link, self.status, estop=self.estop, homed=self.homed,
                               t_write=self.now)
        st = self.emu.process_frame(res.frame)
        n = self.link.sent(res.frame, self.now)
        self.integrity.sent(res.frame, self.now, n)
        if reply:
            # the link delivers in order: a reply is never read before the one sent before it
            t = max(self.now + reply_delay, self._pending[-1][0] if self._pending else 0.0)
            self._pending.append((t, n, st))
            self._deliver()
        sent = Sent(frame, res, st, self.emu.speeds, wait)
        peak = [abs(v) for v in sent.start_speeds]
        left = wait
        while left > 1e-12:
            d = min(0.0005 if self.every_pass else wait, left)
            self.emu.advance(d)
            left -= d
            peak = [max(a, abs(v)) for a, v in zip(peak, self.emu.speeds)]
        sent.peak_speeds = tuple(peak)
        self.log.append(sent)
        self.now += wait
        return res

    def goto(self, positions, speeds=(0, 0, 0, 0, 0, 0), wait: float = PERIOD, **kw) -> GuardResult:
        return self.send(CommandFrame(positions=tuple(int(round(p)) for p in positions),
                                      speeds=tuple(int(round(v)) for v in speeds), command=BoardCommand.GOTO),
                         wait, **kw)

    def idle(self, wait: float = PERIOD) -> GuardResult:
        return self.send(CommandFrame(positions=self.emu.positions, command=BoardCommand.IDLE), wait)

    def over_max(self) -> list[tuple[int, int, float]]:
        """(tick, joint, speed / maximum) of every stepper that ran above its maximum speed."""
        return [(k, j, s.peak_speeds[j] / VMAX[j]) for k, s in enumerate(self.log) for j in range(6)
                if s.peak_speeds[j] > VMAX[j]]
