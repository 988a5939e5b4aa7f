"""The ``record``, ``replay``, ``plot``, ``export`` and ``teach`` sub-commands (argument glue only).

::

    parolkit record [--connect HOST:PORT] [-o run.mcap] [--duration S] [--every N]
    parolkit replay run.mcap [--speed PCT] [--connect HOST:PORT --real-robot] [--record out.mcap]
    parolkit plot run.mcap [-o plot.png|plot.html]
    parolkit export run.mcap --csv [-o run.csv]
    parolkit teach run.mcap -o prog.rbt [--tolerance-mm 5 --tolerance-deg 2]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

__all__ = ["register", "parse_host_port"]


def parse_host_port(text: str) -> tuple[str, int]:
    """``HOST:PORT`` (or ``PORT``) -> (host, port); argparse-friendly errors."""
    host, sep, port_text = text.rpartition(":")
    if not sep:
        host, port_text = "127.0.0.1", text
    try:
        port = int(port_text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected HOST:PORT, got {text!r} (the port is not a number)") from None
    if not 1 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"port {port} is outside 1..65535")
    return (host.strip("[]") or "127.0.0.1"), port


def _positive(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not v > 0 or v == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text}")
    return v


def _percent(text: str) -> float:
    v = _positive(text)
    if v > 100:
        raise argparse.ArgumentTypeError(f"a speed scale is 0 < p <= 100 %, got {text}")
    return v


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser], name: str) -> argparse.ArgumentParser:
    if name == "record":
        p = subparsers.add_parser(name, help="record the controller's status stream to an MCAP file",
                                  description="Record a running controller (an observer: needs no control) "
                                              "to MCAP with ROS 2 schemas (Foxglove, ros2 bag).")
        p.add_argument("--connect", type=parse_host_port, default=("127.0.0.1", 5001), metavar="HOST:PORT",
                       help="the controller (default 127.0.0.1:5001)")
        p.add_argument("-o", "--output", default="run.mcap", help="output file (default run.mcap)")
        p.add_argument("--duration", type=_positive, metavar="S", help="stop after S seconds (default: Ctrl-C)")
        p.add_argument("--every", type=int, default=1, metavar="N", help="record every N-th tick (default 1)")
        p.set_defaults(func=record_main)
    elif name == "replay":
        p = subparsers.add_parser(name, help="play a recorded joint trajectory into a controller",
                                  description="Replay a recording: a planned move to its start pose, then "
                                              "its motion as planned joint moves. Simulated unless "
                                              "--connect and --real-robot are given.")
        p.add_argument("recording")
        p.add_argument("--speed", type=_percent, default=25.0, metavar="PCT",
                       help="speed scale of the move to the start pose, %% (default 25)")
        p.add_argument("--connect", type=parse_host_port, metavar="HOST:PORT",
                       help="replay into this controller instead of a simulated one (needs --real-robot)")
        p.add_argument("--real-robot", action="store_true",
                       help="confirm that --connect may move a real robot")
        p.add_argument("--record", metavar="OUT.mcap", help="record the replay to this file")
        p.add_argument("--tolerance-steps", type=int, default=1,
                       help="largest fit error per tick accepted before refusing to replay (default 1)")
        p.set_defaults(func=replay_main)
    elif name == "plot":
        p = subparsers.add_parser(name, help="plot a recording (joints, speeds, TCP path, loop timing)")
        p.add_argument("recording")
        p.add_argument("-o", "--output", help="plot.png (any matplotlib format) or plot.html (default: recording.png)")
        p.set_defaults(func=plot_main)
    elif name == "export":
        p = subparsers.add_parser(name, help="export a recording for spreadsheets")
        p.add_argument("recording")
        p.add_argument("--csv", action="store_true", required=True, help="write CSV (one row per tick)")
        p.add_argument("-o", "--output", help="output file (default: recording.csv)")
        p.set_defaults(func=export_main)
    elif name == "teach":
        p = subparsers.add_parser(name, help="fit an RBTscript program to a recorded demonstration")
        p.add_argument("recording")
        p.add_argument("-o", "--output", required=True, help="the program to write (prog.rbt)")
        p.add_argument("--tolerance-mm", type=_positive, default=5.0, help="largest TCP deviation, mm (default 5)")
        p.add_argument("--tolerance-deg", type=_positive, default=2.0,
                       help="largest joint / orientation deviation, deg (default 2)")
        p.set_defaults(func=teach_main)
    else:  # pragma: no cover - cli.SUBCOMMANDS names only the five above
        raise ValueError(f"unknown sub-command {name!r}")
    return p


def record_main(args: argparse.Namespace) -> int:
    import signal

    from parolkit.record.recorder import Recorder, RecorderError

    host, port = args.connect
    if args.every < 1:
        print(f"parolkit record: --every must be >= 1, got {args.every}", file=sys.stderr)
        return 2
    rec = Recorder(host, port, args.output, every_n=args.every)
    # SIGINT / SIGTERM: stop recording and write the closing summary
    signal.signal(signal.SIGINT, lambda _s, _f: rec.stop())
    signal.signal(signal.SIGTERM, lambda _s, _f: rec.stop())
    print(f"recording {host}:{port} to {args.output} (Ctrl-C to stop)", flush=True)
    try:
        stats = rec.run(args.duration)
    except RecorderError as exc:
        print(f"parolkit record: {exc} (the file {args.output} is closed and readable)", file=sys.stderr)
        return 1
    print(stats.text(), flush=True)
    return 0


def replay_main(args: argparse.Namespace) -> int:
    from parolkit.record.replay import replay_command

    return int(replay_command(args))


def plot_main(args: argparse.Namespace) -> int:
    from parolkit.record.plot import check_plot_file, plot_recording
    from parolkit.record.reader import load_recording, warn_if_damaged

    out = Path(args.output) if args.output else Path(args.recording).with_suffix(".png")
    check_plot_file(out)
    rec = load_recording(args.recording)
    warn_if_damaged(rec, "plot")
    plot_recording(rec, out)
    print(f"wrote {out}")
    return 0


def export_main(args: argparse.Namespace) -> int:
    from parolkit.record.export import write_csv
    from parolkit.record.reader import load_recording, warn_if_damaged

    rec = load_recording(args.recording)
    warn_if_damaged(rec, "export")
    out = Path(args.output) if args.output else Path(args.recording).with_suffix(".csv")
    rows = write_csv(rec, out)
    print(f"wrote {out} ({rows} rows)")
    return 0


def teach_main(args: argparse.Namespace) -> int:
    from parolkit.record.teach import teach_command

    return int(teach_command(args))
