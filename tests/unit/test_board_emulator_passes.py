"""The emulator's GO TO passes, stepped joint by joint (``BoardEmulator._goto_passes``), give
exactly what the per-pass loop they replaced gave: the same counters, speeds, sub-step phases
and status frames, frame after frame, over random frame sequences (GO TO near and far, with
feed-forward, clamped speeds, settling, IDLE/JOG in between, gripper moves, uneven advances).
Both ways of running them are checked: the compiled kernel (``board/_cgoto.c``, what runs when
it is built) and its Python reference (``emulator.goto_passes``, the fallback)."""

from __future__ import annotations

import os
import random
import types

import pytest

from parolkit import _native
from parolkit.board import BoardEmulator
from parolkit.board import emulator as emulator_module
from parolkit.board.steppers import clamp_speed
from parolkit.protocol.frames import BoardCommand, CommandFrame, GripperCommandBits


def _per_pass_loop(self: BoardEmulator, n: int) -> None:
    """The emulator's GO TO passes as they were before the joint-by-joint stepping (the
    reference); the other branches (homing, JOG, idle) are the emulator's own."""
    g = self._gripper
    if self._homing.active or not (self._enabled and self._command == BoardCommand.GOTO):
        BoardEmulator._run_passes(self, n)
        return
    dt = self._dt
    targets, ff, sts = self._targets, self._ff, self._steppers
    for i in range(n):
        moving = False
        for st, tgt, vff in zip(sts, targets, ff):
            v = clamp_speed(((tgt - st.counter) / 0.01 + vff) / 2)
            st.speed = v
            if v:
                moving = True
                st.run(v, dt)
        if g.busy:
            g.advance(dt)
        if not moving:
            for st in sts:
                st.stop_phase()
            rest = n - i - 1
            if rest and g.busy:
                for _ in range(rest):
                    g.advance(dt)
            break
    self._t += n * dt


def _frames(rng: random.Random, count: int) -> list[tuple[CommandFrame, float]]:
    """Random frames, each with the board time that passes after it (s)."""
    out = []
    pos = [10240, -32000, 57905, 0, 0, 32000]
    for _ in range(count):
        r = rng.random()
        if r < 0.2:  # hold the last target: the joints settle within the passes
            frame = CommandFrame(command=BoardCommand.GOTO, positions=tuple(pos))
            out.append((frame, rng.choice([0.01, 0.05, 0.3])))
            continue
        if r < 0.75:
            far = rng.choice([3, 30, 300, 3000, 30000])
            pos = [p + rng.randint(-far, far) for p in pos]
            speeds = [rng.choice([0, 0, rng.randint(-9000, 9000)]) for _ in range(6)]
            frame = CommandFrame(command=BoardCommand.GOTO, positions=tuple(pos), speeds=tuple(speeds))
        elif r < 0.85:
            frame = CommandFrame(command=BoardCommand.JOG, speeds=tuple(rng.randint(-3000, 3000) for _ in range(6)))
        elif r < 0.92:
            frame = CommandFrame(command=BoardCommand.IDLE)
        else:
            frame = CommandFrame(command=BoardCommand.GOTO, positions=tuple(pos),
                                 gripper_position=rng.randint(0, 255), gripper_speed=rng.randint(1, 255),
                                 gripper_current=600,
                                 gripper_command=GripperCommandBits.ACTIVATE | GripperCommandBits.MOVE)
        out.append((frame, rng.choice([0.01, 0.01, 0.01, 0.004, 0.0005, 0.03])))
    return out


def _state(emu: BoardEmulator) -> tuple[object, ...]:
    return (tuple((st.counter, st.speed, st._acc) for st in emu._steppers), emu._t, emu._gripper.position)


PURE = os.environ.get("PAROLKIT_PURE_PYTHON", "") not in ("", "0")
#: the ways the emulator may run its GO TO passes
KERNELS = {"reference": emulator_module.goto_passes}
if emulator_module._cgoto is not None:
    KERNELS["compiled"] = emulator_module._cgoto.passes


def test_the_goto_kernel_is_built_in_this_checkout():
    if PURE:
        pytest.skip("PAROLKIT_PURE_PYTHON is set")
    assert emulator_module._goto_passes is getattr(emulator_module._cgoto, "passes", None), (
        "the compiled GO TO passes are missing: "
        f"{_native.status().get('parolkit.board._cgoto')}; `pip install -e .` needs a C compiler")


@pytest.mark.parametrize("kernel", sorted(KERNELS))
@pytest.mark.parametrize("seed", range(12))
def test_joint_by_joint_goto_passes_equal_the_per_pass_loop(seed, kernel, monkeypatch):
    monkeypatch.setattr(emulator_module, "_goto_passes", KERNELS[kernel])
    rng = random.Random(seed)
    new = BoardEmulator(clock="virtual", start_homed=True, pass_hz=rng.choice([1000, 2000, 5000]))
    old = BoardEmulator(clock="virtual", start_homed=True, pass_hz=new.pass_hz)
    old._run_passes = types.MethodType(_per_pass_loop, old)  # type: ignore[method-assign]
    for frame, dt in _frames(rng, 300):
        assert new.process_frame(frame).encode() == old.process_frame(frame).encode()
        new.advance(dt)
        old.advance(dt)
        assert _state(new) == _state(old)
