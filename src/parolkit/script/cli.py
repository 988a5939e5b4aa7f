"""``parolkit run`` / ``parolkit check`` / ``parolkit fmt``: RBTscript from the command line.

::

    parolkit run PROGRAM [--sim [--fast] [--frame-log FILE]] [--host H --port P [--ack-port A]] [--dry-run]
                         [--plot out.png] [--step] [--loops N] [--from J1 .. J6] [--tool NAME] [--config FILE]
                         [--quiet]
    parolkit check PROGRAM... [--no-plan] [--table] [--loops N] [--from J1 .. J6] [--tool NAME] [--strict]
                              [--config FILE]
    parolkit fmt PROGRAM... [--check] [--stdout]

The dry run (``check``, ``run --dry-run``) checks every move for collisions with the config's
keep-out zones (``[[zones]]``; the table plane by default), the arm's own links and the tool's
body (``[tools.NAME] shape`` of ``--tool NAME``); a collision is an error at its line naming
the pair and the time into the move.  The config is ``--config FILE``, else the default file
(``./parolkit.toml``, then ``~/.config/parolkit/parolkit.toml``), else the defaults.

``run --sim`` runs the controller in this process on a simulated board in lockstep with its
frames (:class:`parolkit.controller.fastforward.InProcessController`): each command reaches
it at a tick fixed by the program, so a run paced at real time and a ``--fast`` one (no
sleeping: as fast as the machine computes the ticks) write the same frames (``--frame-log``).

Exit status: 0 success; 1 the program has errors (nothing moved), the run failed or a file
is not formatted (``fmt --check``); 2 bad command line; 130 interrupted (Ctrl-C sends STOP).
"""

from __future__ import annotations

import argparse
import sys
import threading
import time
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, TextIO

if TYPE_CHECKING:
    from parolkit.client.robot import Robot
    from parolkit.config import Config, ToolSettings
    from parolkit.kinematics.tools import Tool
    from parolkit.script.interpreter import Interpreter, Progress
    from parolkit.script.parser import Limits
    from parolkit.script.program import Program, ScriptError

__all__ = ["register", "run_main", "check_main", "fmt_main"]

_DESCRIPTIONS = {
    "run": (
        "run an RBTscript program",
        "Check a program (every error at once, then a dry run of every move from the robot's "
        "current joints) and run it on the controller, showing the current line and the "
        "elapsed/planned time. Nothing moves when the program has an error.",
    ),
    "check": (
        "check RBTscript programs without running them",
        "Parse and dry-run programs (from the standby pose unless --from is given): syntax, "
        "argument counts and ranges, reachability, path validity and collisions (the arm with "
        "itself, its tool and the config's keep-out zones, the table by default). Exit 1 on any error.",
    ),
    "fmt": (
        "format RBTscript programs",
        "Rewrite programs in canonical form (original spellings, ', ' between arguments, "
        "shortest numbers, comments kept). Programs with errors are left alone.",
    ),
}


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser],
             name: str) -> argparse.ArgumentParser:
    """Add the ``run``, ``check`` or ``fmt`` parser (``name``) to ``subparsers``."""
    if name not in _DESCRIPTIONS:
        raise ValueError(f"parolkit.script.cli provides run, check and fmt, not {name!r}")
    help_text, description = _DESCRIPTIONS[name]
    p = subparsers.add_parser(name, help=help_text, description=description)
    if name == "run":
        p.add_argument("program", help="the .rbt program file")
        p.add_argument("--sim", action="store_true",
                       help="run a controller with the simulated board in this process for this run")
        p.add_argument("--fast", action="store_true",
                       help="with --sim: fast-forward (no waiting for the clock; the same frames as "
                            "a real-time run, as fast as this machine computes them)")
        p.add_argument("--frame-log", metavar="FILE", default=None,
                       help="with --sim: write every frame sent to the board to FILE, one line each: "
                            "tick index, bytes in hex")
        p.add_argument("--host", default="127.0.0.1", help="controller address (default 127.0.0.1)")
        p.add_argument("--port", type=int, default=None,
                       help="controller UDP port (default: from the config, 5001)")
        p.add_argument("--ack-port", type=int, default=None,
                       help="local UDP port the controller sends acknowledgements to "
                            "(default: from the config, 5002)")
        p.add_argument("--dry-run", action="store_true",
                       help="plan everything without a robot and print the per-line table")
        p.add_argument("--plot", metavar="PNG", default=None,
                       help="draw joint positions and speeds of the whole program into PNG")
        p.add_argument("--step", action="store_true",
                       help="single-step: Enter runs the next command, c continues, q stops")
        _common(p)
        p.add_argument("--quiet", "-q", action="store_true", help="no progress lines")
        p.set_defaults(func=run_main)
    elif name == "check":
        p.add_argument("programs", nargs="+", help="the .rbt program files")
        p.add_argument("--no-plan", action="store_true", help="syntax and ranges only (no dry run)")
        p.add_argument("--table", action="store_true", help="print the per-line dry-run table")
        p.add_argument("--strict", action="store_true", help="treat warnings as errors")
        _common(p)
        p.set_defaults(func=check_main)
    else:
        p.add_argument("programs", nargs="+", help="the .rbt program files")
        p.add_argument("--check", action="store_true",
                       help="change nothing; exit 1 if a file is not formatted")
        p.add_argument("--stdout", action="store_true", help="print the result instead of rewriting")
        p.set_defaults(func=fmt_main)
    return p


def _common(p: argparse.ArgumentParser) -> None:
    from parolkit.script.dryrun import MAX_DRY_RUN_PASSES

    p.add_argument("--loops", type=_positive_int, default=None, metavar="N",
                   help="passes of a Loop() program (run: default forever; check: default 2). Any "
                        "number is checked in a few passes when the program comes back to where a pass "
                        f"started; one that drifts is planned for at most {MAX_DRY_RUN_PASSES} passes, "
                        "with a warning")
    p.add_argument("--from", dest="start", nargs=6, type=float, metavar="J", default=None,
                   help="start joint angles (deg) for a dry run; default the standby pose "
                        "90 -90 180 0 0 180")
    p.add_argument("--tool", default=None, metavar="NAME",
                   help="the tool the dry run plans and checks with: a [tools.NAME] of the config (its "
                        "shape is checked for collisions) or a built-in (default, flange); default: the "
                        "default tool. A run on a robot uses the controller's tool")
    p.add_argument("--config", default=None, metavar="FILE",
                   help="parolkit.toml to use (robot limits, tools, [[zones]]); default ./parolkit.toml, "
                        "then ~/.config/parolkit/parolkit.toml")


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 1, got {value}")
    return value


def _config(args: argparse.Namespace) -> Config:
    from parolkit.config import load_config

    return load_config(args.config)


def _tool(args: argparse.Namespace, cfg: Config) -> tuple[Tool | None, ToolSettings | None]:
    """``--tool NAME``: the kinematics tool the dry run plans with and the config entry whose
    shape it checks (None, None without --tool).  An unknown name raises ParolkitValueError."""
    if args.tool is None:
        return None, None
    from parolkit.kinematics.tools import get_tool

    tool = get_tool(args.tool, cfg)
    return tool, next((t for t in cfg.tools if t.name == args.tool), None)


def _limits(cfg: Config) -> Limits:
    from parolkit.script.parser import Limits

    return Limits.from_model(cfg.robot, rate_hz=cfg.controller.rate_hz)


def _print_diagnostics(diags: Iterable[ScriptError], stream: TextIO | None = None) -> None:
    stream = stream or sys.stderr
    for d in diags:
        print(d.format(), file=stream)


# ------------------------------------------------------------------------------------------
# check
# ------------------------------------------------------------------------------------------


def check_main(args: argparse.Namespace) -> int:
    from parolkit.errors import ParolkitError
    from parolkit.script.parser import parse_file

    try:
        cfg = _config(args)
        tool, tool_shape = _tool(args, cfg)
    except ParolkitError as exc:
        print(f"parolkit check: {exc}", file=sys.stderr)
        return 2
    limits = _limits(cfg)
    failed = False
    for name in args.programs:
        result = parse_file(name, limits=limits)
        if not result.ok:
            _print_diagnostics(result.diagnostics(), sys.stdout)
            print(f"{name}: {len(result.errors)} error(s)")
            failed = True
            continue
        program = result.program
        if program is None:
            raise RuntimeError(f"{name}: the parser found no error but returned no program")
        errors: tuple[ScriptError, ...] = ()
        warnings = result.warnings
        report = None
        if not args.no_plan:
            from parolkit.script.dryrun import dry_run

            report = dry_run(program, args.start, loops=args.loops, model=cfg.robot, tool=tool,
                             rate_hz=cfg.controller.rate_hz, zones=cfg.zones, tool_shape=tool_shape)
            errors, warnings = report.errors, report.warnings
        diags = sorted(errors + warnings, key=lambda d: (d.line, d.col))
        _print_diagnostics(diags, sys.stdout)
        if report is not None and args.table:
            print(report.table())
        bad = bool(errors) or (args.strict and bool(warnings))
        failed |= bad
        if bad:
            print(f"{name}: {len(errors)} error(s), {len(warnings)} warning(s)")
        else:
            planned = f", planned {report.total_s:.2f} s" if report is not None else ""
            if report is not None and report.counted_iterations < report.iterations:
                planned += f" for the first {report.counted_iterations} of {report.iterations} passes"
            elif report is not None and report.iterations > 1:
                planned += f" for {report.iterations} passes"
            if report is not None and report.repeat_note:
                planned += f"; {report.repeat_note}"
            print(f"{name}: OK, {len(program)} commands{planned}")
    return 1 if failed else 0


# ------------------------------------------------------------------------------------------
# fmt
# ------------------------------------------------------------------------------------------


def fmt_main(args: argparse.Namespace) -> int:
    from parolkit.script.formatter import format_program
    from parolkit.script.parser import read_source
    from parolkit.script.program import ProgramError, ScriptError

    status = 0
    for name in args.programs:
        path = Path(name)
        original = read_source(path)
        if isinstance(original, ScriptError):
            _print_diagnostics([original])
            status = 1
            continue
        try:
            formatted = format_program(original, name)
        except ProgramError as exc:
            _print_diagnostics(exc.errors)
            print(f"{name}: not formatted ({len(exc.errors)} error(s))", file=sys.stderr)
            status = 1
            continue
        if args.stdout:
            sys.stdout.write(formatted)
        elif formatted != original:
            if args.check:
                print(f"{name}: would be reformatted")
                status = 1
            else:
                path.write_text(formatted, encoding="utf-8")
                print(f"{name}: formatted")
    return status


# ------------------------------------------------------------------------------------------
# run
# ------------------------------------------------------------------------------------------


def _fmt_joints(q: Iterable[float]) -> str:
    return "[" + ", ".join(f"{v:.3f}" for v in q) + "]"


class _ProgressPrinter:
    """Prints ``[elapsed / planned] line N: command`` as each command starts.  On a terminal
    the current line is rewritten in place with the running time (every 0.2 s)."""

    def __init__(self, loops: bool, live: bool) -> None:
        self.loops = loops
        self.live = live
        self._lock = threading.Lock()
        self._current: Progress | None = None
        self._since = 0.0
        self._open = False

    def _text(self, p: Progress, elapsed: float) -> str:
        total = f"{p.planned_total_s:.1f}" if p.planned_total_s is not None else f"{p.planned_pass_s:.1f}/pass"
        it = f" pass {p.iteration}" if self.loops else ""
        return f"[{elapsed:6.1f} s / {total} s] line {p.line}{it}: {p.command}"

    def on_line(self, p: Progress) -> None:
        with self._lock:
            self._current = p
            self._since = time.monotonic()
            text = self._text(p, p.elapsed_s)
            if self.live:
                sys.stdout.write(("\n" if self._open else "") + text)
                self._open = True
                sys.stdout.flush()
            else:
                print(text, flush=True)

    def tick(self) -> None:
        with self._lock:
            p = self._current
            if not self.live or p is None:
                return
            elapsed = p.elapsed_s + time.monotonic() - self._since
            sys.stdout.write("\r" + self._text(p, elapsed) + "\x1b[K")
            sys.stdout.flush()

    def close(self) -> None:
        with self._lock:
            if self._open:
                sys.stdout.write("\n")
                sys.stdout.flush()
                self._open = False


def _dry_run_main(args: argparse.Namespace, program: Program, cfg: Config) -> int:
    from parolkit.script.dryrun import dry_run

    tool, tool_shape = _tool(args, cfg)
    report = dry_run(program, args.start, loops=args.loops, model=cfg.robot, tool=tool,
                     rate_hz=cfg.controller.rate_hz, zones=cfg.zones, tool_shape=tool_shape)
    _print_diagnostics(sorted(report.errors + report.warnings, key=lambda d: (d.line, d.col)))
    print(report.table())
    if args.plot:
        report.plot(args.plot)
        print(f"plot: {args.plot}")
    if not report.ok:
        print(f"{program.source_name}: {len(report.errors)} error(s): nothing would run", file=sys.stderr)
        return 1
    print(f"final joints: {_fmt_joints(report.final_deg)} deg")
    return 0


def _step_console(interp: Interpreter, done: threading.Event) -> None:
    """Single-step prompts on the terminal (runs in the main thread)."""
    from parolkit.script.interpreter import InterpreterState

    while not done.is_set():
        if interp.state is not InterpreterState.PAUSED:
            done.wait(0.05)
            continue
        index = interp.current_index
        cmd = interp.program.commands[index] if index is not None else None
        where = f"line {cmd.line}: {cmd.to_source()}" if cmd is not None else "next command"
        try:
            answer = input(f"{where}   [Enter] step, c continue, q stop > ").strip().lower()
        except EOFError:
            answer = "q"
        if answer in ("q", "quit", "stop"):
            interp.stop()
            return
        if answer in ("c", "continue"):
            interp.resume()
            return
        started = interp.commands_started
        interp.step()
        # wait until that command has started before prompting again
        while interp.commands_started == started and not done.is_set():
            done.wait(0.01)


def _sim_flag_error(args: argparse.Namespace) -> str | None:
    """What is wrong with --fast / --frame-log on this command line (None: nothing)."""
    if args.tool is not None and not args.dry_run:
        return ("--tool applies to --dry-run (the tool it plans and checks with); a run uses the "
                "controller's tool (SET_TOOL|NAME, Robot.set_tool)")
    for flag, given in (("--fast", args.fast), ("--frame-log", args.frame_log is not None)):
        if given and not args.sim:
            return (f"{flag} needs --sim: it runs the simulated board in this process, in lockstep "
                    "with the frames (a controller over UDP runs on its own clock)")
        if given and args.dry_run:
            return f"{flag} applies to a --sim run; --dry-run only plans (nothing is sent to a board)"
    if args.frame_log is not None and not args.frame_log:
        return "--frame-log needs a file name"
    return None


def run_main(args: argparse.Namespace) -> int:
    from parolkit.errors import ParolkitError
    from parolkit.script.parser import parse_file

    bad = _sim_flag_error(args)
    if bad is not None:
        print(f"parolkit run: {bad}", file=sys.stderr)
        return 2
    try:
        cfg = _config(args)
    except ParolkitError as exc:
        print(f"parolkit run: {exc}", file=sys.stderr)
        return 2
    result = parse_file(args.program, limits=_limits(cfg))
    if not result.ok:
        _print_diagnostics(result.diagnostics())
        print(f"{args.program}: {len(result.errors)} error(s): nothing was run", file=sys.stderr)
        return 1
    program = result.program
    if program is None:
        raise RuntimeError(f"{args.program}: the parser found no error but returned no program")
    if args.dry_run:
        return _dry_run_main(args, program, cfg)
    if result.warnings and not args.quiet:
        _print_diagnostics(result.warnings)

    from parolkit.client.robot import Robot

    if args.sim:
        return _run_sim(args, program, cfg)
    port = args.port if args.port is not None else cfg.controller.udp_port
    ack_port = args.ack_port if args.ack_port is not None else cfg.controller.ack_port
    try:
        robot = Robot(args.host, port, ack_port=ack_port)
    except (ParolkitError, OSError) as exc:
        print(f"parolkit run: {exc}", file=sys.stderr)
        return 1
    try:
        return _run_program(args, program, cfg, robot)
    finally:
        robot.close()


def _run_sim(args: argparse.Namespace, program: Program, cfg: Config) -> int:
    """``run --sim``: the controller in this process on a simulated board in lockstep, paced at
    real time or fast-forwarded (``--fast``); the composition root of that run."""
    from parolkit.client.robot import Robot
    from parolkit.controller.fastforward import InProcessController
    from parolkit.errors import ParolkitError

    log: TextIO | None = None
    if args.frame_log is not None:
        try:
            log = open(args.frame_log, "w", encoding="ascii")  # closed below
        except OSError as exc:
            print(f"parolkit run: --frame-log {args.frame_log}: {exc.strerror or exc}", file=sys.stderr)
            return 2
    sim: InProcessController | None = None
    robot: Robot | None = None
    try:
        sim = InProcessController(cfg, paced=not args.fast, frame_log=log)
        if not args.quiet:
            print("starting a controller with the simulated board"
                  + (" (fast-forward) ..." if args.fast else " ..."), flush=True)
        sim.start()
        robot = Robot(channel=sim)
        t0, ticks0 = time.monotonic(), sim.ticks
        rc = _run_program(args, program, cfg, robot)
        if args.fast and not args.quiet:
            wall = time.monotonic() - t0
            board = (sim.ticks - ticks0) * sim.period
            ratio = f", {board / wall:.0f}x real time" if wall > 0 else ""
            print(f"fast-forward: {board:.2f} s of board time in {wall:.2f} s{ratio}")
        return rc
    except (ParolkitError, RuntimeError, OSError) as exc:
        print(f"parolkit run: {exc}", file=sys.stderr)
        return 1
    finally:
        if robot is not None:
            robot.close()
        if sim is not None:
            sim.close()
        if log is not None:
            log.close()


def _run_program(args: argparse.Namespace, program: Program, cfg: Config, robot: Robot) -> int:
    """Run ``program`` on ``robot`` with progress lines, single-stepping, Ctrl-C (STOP) and the
    final report; the exit status."""
    from parolkit.errors import ParolkitError
    from parolkit.script.interpreter import Interpreter

    try:
        quiet = args.quiet
        progress = _ProgressPrinter(program.loops, live=sys.stdout.isatty() and not args.step)
        interp = Interpreter(program, robot, on_line=None if quiet else progress.on_line,
                             loops=args.loops, step=args.step, model=cfg.robot,
                             rate_hz=cfg.controller.rate_hz)
        done = threading.Event()

        def body() -> None:
            try:
                interp.run()
            finally:
                done.set()

        thread = threading.Thread(target=body, name="rbtscript", daemon=True)
        thread.start()
        try:
            if args.step:
                _step_console(interp, done)
            while not done.wait(0.2):
                if not quiet:
                    progress.tick()
            if not quiet:
                progress.close()
        except KeyboardInterrupt:
            print("\ninterrupted: stopping the robot", file=sys.stderr)
            interp.stop()
            done.wait(10)
            return 130
        thread.join(5)
        res = interp.result
        if res is None:
            print("the run did not end cleanly", file=sys.stderr)
            return 1
        if res.errors:
            _print_diagnostics(res.errors)
        if args.plot and interp.report is not None:
            interp.report.plot(args.plot)
            print(f"plot: {args.plot}")
        print(res.message)
        if res.final_deg is not None:
            print(f"final joints: {_fmt_joints(res.final_deg)} deg")
        return 0 if res.ok else 1
    except (ParolkitError, RuntimeError, OSError) as exc:
        print(f"parolkit run: {exc}", file=sys.stderr)
        return 1
