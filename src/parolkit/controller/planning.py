"""Planning a motion command: a pure function, run off the tick by the driver's planner.

The controller core never plans: it asks (:class:`PlanRequest`, in its tick output) and takes
the answer in a later tick (:class:`PlanResult`, in its tick input).  A request carries
everything the plan depends on (the command, where it starts, the tool, the rate, the robot),
so :func:`plan` needs nothing else and the same request always gives the same result: the
driver may run it in a worker thread (real time), inline (fast-forward, deterministic tests)
or ahead of the tick (the UDP server starts planning a move that reaches an idle robot before
the tick takes the command in).  ``parolkit.motion`` (numpy, the planners) is imported on the
first plan, off the start-up path.
"""

from __future__ import annotations

import importlib
import logging
from collections.abc import Sequence
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any

from parolkit.controller.activities import Samples
from parolkit.controller.world import CollisionWorld, check_plan
from parolkit.protocol import commands as C
from parolkit.robot import RobotModel

__all__ = ["PlanRequest", "PlanResult", "plan", "needs_plan"]

log = logging.getLogger("parolkit.controller")


def needs_plan(cmd: C.Command) -> bool:
    """True for the commands whose motion is planned whole before it runs (the command class
    says so: :attr:`parolkit.protocol.commands.Command.EXECUTION`)."""
    return cmd.EXECUTION is C.Execution.PLANNED


@dataclass(frozen=True)
class PlanRequest:
    """Plan ``command`` from ``start_deg`` (J1..J6, deg) with ``tool`` at ``rate_hz``.

    ``key`` identifies the request to whoever made it (the core: the job's number; the
    server's plan ahead: a negative number of its own); ``jog_start`` continues a streamed
    Cartesian jog from where the previous one was (``parolkit.motion.cartesian.JogStart``);
    ``tool`` None: the tool called ``tool_name`` (resolved here, off the tick)."""

    key: int
    command: C.Command
    start_deg: tuple[float, ...]
    tool_name: str
    tool: object | None
    rate_hz: float
    model: RobotModel = field(repr=False, compare=False)
    jog_start: object | None = None
    #: the configuration whose ``[tools.NAME]`` a ``tool`` of None is resolved by name from
    config: object | None = field(default=None, repr=False, compare=False)
    #: the queued commands ``command`` blends into (issue 24): planned with it as one
    #: trajectory (:func:`parolkit.motion.blending.plan_blended`); () for a move on its own
    chain: tuple[C.Command, ...] = ()
    #: the collision world the move will run in (its plan is checked there before it is
    #: admitted, when its command says so: ``COLLISION`` PLAN); None: not checked
    world: CollisionWorld | None = None
    #: the speed override (%) in force: the times of a refusal's words are at it
    speed_pct: float = 100.0


@dataclass(frozen=True)
class PlanResult:
    """The answer to the request with ``key``: the trajectory and its samples (plain lists,
    built here, off the tick), the final joints, the planner's notes, or the error; and how
    long planning took (s, measured by whoever ran it)."""

    key: int
    command: C.Command
    start_deg: tuple[float, ...]
    tool_name: str
    trajectory: object | None = None
    samples: Samples | None = None
    final_deg: tuple[float, ...] | None = None
    notes: tuple[str, ...] = ()
    error: str | None = None
    seconds: float = 0.0
    #: a blended chain's plan: for its first command and each of the request's ``chain`` but
    #: the last, the sample after which that command is done
    marks: tuple[int, ...] = ()
    #: the collision world it was checked in (the request's)
    world: CollisionWorld | None = None


_motion: ModuleType | None = None


def _motion_module() -> ModuleType:
    global _motion
    if _motion is None:
        _motion = importlib.import_module("parolkit.motion")
    return _motion


def plan(req: PlanRequest) -> PlanResult:
    """Plan ``req``; every planning error (refusals, IK failures, bad values) becomes the
    result's ``error`` with the planner's words."""
    base: dict[str, Any] = {"key": req.key, "command": req.command, "start_deg": req.start_deg,
                            "tool_name": req.tool_name, "world": req.world}
    try:
        if not needs_plan(req.command):
            raise TypeError(f"{req.command.name} is not a planned motion command")
        move = req.command.move  # type: ignore[attr-defined]
        tool = req.tool
        if tool is None:
            tools = importlib.import_module("parolkit.kinematics.tools")
            tool = tools.get_tool(req.tool_name, req.config)
        marks: tuple[int, ...] = ()
        if req.chain:
            blending = importlib.import_module("parolkit.motion.blending")
            moves = [move, *(c.move for c in req.chain)]  # type: ignore[attr-defined]
            bp = blending.plan_blended(moves, req.start_deg, model=req.model, tool=tool, rate_hz=req.rate_hz)
            traj, marks = bp.trajectory, bp.marks
        else:
            traj = _motion_module().plan(move, req.start_deg, model=req.model, tool=tool, rate_hz=req.rate_hz,
                                         jog_start=req.jog_start)
        if len(traj) == 0:
            return PlanResult(**base, error="the move plans to zero samples")
        if req.world is not None and req.command.COLLISION is C.CollisionCheck.PLAN:
            # admitted only when no pose of it (samples and between them) is within a margin
            collision = check_plan(req.world, traj.positions_deg(), traj.rate_hz, req.start_deg, req.speed_pct)
            if collision is not None:
                return PlanResult(**base, error=f"would collide: {collision}")
        samples: Samples = (traj.positions.tolist(), traj.speeds.tolist(), traj.commands.tolist())
        final: Sequence[float] = traj.final_deg
        return PlanResult(**base, trajectory=traj, samples=samples, final_deg=tuple(float(v) for v in final),
                          notes=tuple(getattr(traj, "notes", ())), marks=marks)
    except Exception as exc:  # PlanningError, IKError, value errors: all become FAILED
        msg = str(exc) or type(exc).__name__
        log.info("planning %s failed: %s", req.command.name, msg)
        return PlanResult(**base, error=msg)
