"""The planned trajectory: plain arrays a control loop plays with zero per-tick computation.

Sample convention: ``t[0] = 1 / rate_hz`` (the first tick after the start), one sample every
``1 / rate_hz`` s.  For POSITION tracking (board command 156) ``positions[-1]`` is exactly the
target in steps; SPEED tracking streams (board command 123) end with a zero-speed sample.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, TypeVar

import numpy as np

from parolkit.robot import PAROL6, RobotModel

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from parolkit.kinematics import Tool

__all__ = ["Trajectory"]


_Array = TypeVar("_Array", bound=np.ndarray)


def _frozen(a: _Array) -> _Array:
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A planned move, sample by sample.

    Attributes:
        t: (N,) sample times in s from the start of the move.
        positions: (N, 6) int64 joint positions in microsteps.
        speeds: (N, 6) int64 feed-forward joint speeds in microsteps/s.
        commands: (N,) uint8 board command per sample: 156 (position + speed) or 123 (speed).
        rate_hz: sample rate (Hz).
        move: the request this was planned from.
        notes: what the planner decided for the caller, e.g. ``"duration stretched from 0.5 s
            to 1.2 s: J2 speed limit"``.
        start_deg: (6,) joint angles (deg) the move starts from.
        model: the robot model the steps refer to.
        planned_deg: (N, 6) float joint angles (deg) before rounding to steps (what the
            planner computed; FK of these lies exactly on the path), or None.
    """

    t: NDArray[np.float64]
    positions: NDArray[np.int64]
    speeds: NDArray[np.int64]
    commands: NDArray[np.uint8]
    rate_hz: float
    move: object
    notes: tuple[str, ...] = ()
    start_deg: NDArray[np.float64] = field(default_factory=lambda: np.zeros(6))
    model: RobotModel = PAROL6
    planned_deg: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "t", _frozen(np.asarray(self.t, dtype=float)))
        object.__setattr__(self, "positions", _frozen(np.asarray(self.positions, dtype=np.int64)))
        object.__setattr__(self, "speeds", _frozen(np.asarray(self.speeds, dtype=np.int64)))
        object.__setattr__(self, "commands", _frozen(np.asarray(self.commands, dtype=np.uint8)))
        object.__setattr__(self, "start_deg", _frozen(np.asarray(self.start_deg, dtype=float)))
        object.__setattr__(self, "notes", tuple(self.notes))
        if self.planned_deg is not None:
            object.__setattr__(self, "planned_deg", _frozen(np.array(self.planned_deg, dtype=float)))
        n = len(self.t)
        if self.positions.shape != (n, 6) or self.speeds.shape != (n, 6) or self.commands.shape != (n,):
            raise ValueError(
                f"inconsistent trajectory arrays: t {self.t.shape}, positions "
                f"{self.positions.shape}, speeds {self.speeds.shape}, commands {self.commands.shape}"
            )

    @classmethod
    def _trusted(
        cls, t: NDArray[np.float64], positions: NDArray[np.int64], speeds: NDArray[np.int64],
        commands: NDArray[np.uint8], rate_hz: float, move: object, notes: tuple[str, ...],
        start_deg: NDArray[np.float64], model: RobotModel, planned_deg: NDArray[np.float64] | None,
    ) -> Trajectory:
        """Internal constructor for arrays the planner built itself with the right dtypes and
        shapes (t float (N,), positions/speeds int64 (N, 6), commands uint8 (N,), start_deg
        float (6,), planned_deg float (N, 6)): they are frozen in place, not converted or
        re-checked.  Arrays may be shared read-only caches (t, commands).  User code builds
        Trajectories with the normal constructor, which converts and validates."""
        for a in (positions, speeds, start_deg, planned_deg):
            if a is not None and a.flags.writeable:  # (the compiled planner's are read-only)
                a.setflags(write=False)
        obj = object.__new__(cls)
        obj.__dict__.update(
            t=t, positions=positions, speeds=speeds, commands=commands, rate_hz=rate_hz,
            move=move, notes=notes, start_deg=start_deg, model=model, planned_deg=planned_deg,
        )
        return obj

    def with_notes(self, notes: Sequence[str], move: object = None) -> Trajectory:
        """The same samples with ``notes`` (and ``move``, when given) instead of its own: a
        planner that wraps another one's trajectory (a stretched or blended move) says so."""
        return Trajectory._trusted(self.t, self.positions, self.speeds, self.commands, self.rate_hz,
                                   self.move if move is None else move, tuple(notes), self.start_deg, self.model,
                                   self.planned_deg)

    def __repr__(self) -> str:
        return (f"Trajectory({self.name}, {len(self)} samples at {self.rate_hz:g} Hz, "
                f"{self.duration:.3f} s, notes={list(self.notes)!r})")

    def __len__(self) -> int:
        return len(self.t)

    @property
    def duration(self) -> float:
        """Time of the last sample (s); 0 for an empty trajectory."""
        return float(self.t[-1]) if len(self.t) else 0.0

    @property
    def name(self) -> str:
        """Name of the move kind (``"MoveJoint"``, ...)."""
        return getattr(self.move, "name", type(self.move).__name__)

    def positions_deg(self) -> NDArray[np.float64]:
        """(N, 6) joint positions in degrees."""
        deg: NDArray[np.float64] = self.positions / self.model.steps_per_deg
        return deg

    def speeds_deg_s(self) -> NDArray[np.float64]:
        """(N, 6) joint speeds in deg/s."""
        deg_s: NDArray[np.float64] = self.speeds / self.model.steps_per_deg
        return deg_s

    @property
    def final_deg(self) -> NDArray[np.float64]:
        """(6,) joint angles (deg) of the last sample (the start when empty)."""
        if not len(self.t):
            return np.array(self.start_deg)
        deg: NDArray[np.float64] = self.positions[-1] / self.model.steps_per_deg
        return deg

    @property
    def final_steps(self) -> NDArray[np.int64]:
        """(6,) int64 joint positions of the last sample."""
        return np.array(self.positions[-1]) if len(self.t) else np.rint(
            self.start_deg * self.model.steps_per_deg
        ).astype(np.int64)

    def peak_speeds_steps_s(self) -> NDArray[np.int64]:
        """(6,) largest |speed| per joint, steps/s."""
        return np.abs(self.speeds).max(axis=0) if len(self.t) else np.zeros(6, dtype=np.int64)

    def tcp_path_mm(self, tool: str | Tool | None = None, max_points: int = 400) -> NDArray[np.float64]:
        """(M, 3) tool positions (mm, WRF) along the move, M <= ``max_points`` (start and end
        included).  Uses forward kinematics (imported lazily)."""
        from parolkit import kinematics

        q = np.vstack([self.start_deg[None, :], self.positions_deg()])
        if max_points < 2:
            max_points = 2
        if len(q) > max_points:
            idx = np.unique(np.linspace(0, len(q) - 1, max_points).round().astype(int))
            q = q[idx]
        poses = np.asarray(kinematics.fk_batch(q, tool))
        return np.array(poses[:, :3], dtype=float)

    def poses(self, tool: str | Tool | None = None) -> NDArray[np.float64]:
        """(N, 6) tool poses [x, y, z mm, A, B, C deg] of every sample (forward kinematics)."""
        from parolkit import kinematics

        return np.asarray(kinematics.fk_batch(self.positions_deg(), tool), dtype=float)

    def summary(self) -> str:
        """A few lines for people: duration, samples, peak speeds, notes."""
        peaks = self.peak_speeds_steps_s()
        lines = [
            f"{self.name}: {len(self)} samples at {self.rate_hz:g} Hz, duration {self.duration:.3f} s, "
            f"board command {int(self.commands[-1]) if len(self) else '-'}",
            "peak speed (steps/s): " + "  ".join(f"J{i + 1} {int(p)}" for i, p in enumerate(peaks)),
        ]
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)

    @staticmethod
    def concatenate(parts: Sequence[Trajectory], move: object, notes: Sequence[str] = ()) -> Trajectory:
        """Play ``parts`` one after another as one trajectory for ``move``."""
        parts = [p for p in parts if len(p)]
        if not parts:
            raise ValueError("nothing to concatenate")
        offs = 0.0
        ts = []
        for p in parts:
            ts.append(p.t + offs)
            offs += p.duration
        all_notes = list(notes)
        for p in parts:
            all_notes += [n for n in p.notes if n not in all_notes]
        return Trajectory(
            t=np.concatenate(ts),
            positions=np.concatenate([p.positions for p in parts]),
            speeds=np.concatenate([p.speeds for p in parts]),
            commands=np.concatenate([p.commands for p in parts]),
            rate_hz=parts[0].rate_hz, move=move, notes=tuple(all_notes),
            start_deg=parts[0].start_deg, model=parts[0].model,
            planned_deg=(np.concatenate([p.planned_deg for p in parts])
                         if all(p.planned_deg is not None for p in parts) else None),
        )
