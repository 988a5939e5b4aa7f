"""``parolkit urdf`` and ``parolkit ros2``.

    parolkit urdf [-o parol6.urdf] [--tool NAME] [--config FILE]
    parolkit ros2 [--connect HOST:PORT] [--domain N] [--namespace NS] [--frame-prefix P] [--config FILE]

``urdf`` needs only numpy; ``ros2`` needs the optional ``cyclonedds`` package
(``pip install 'parolkit[ros2]'``) and is imported only when run.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from parolkit.errors import ParolkitError

__all__ = ["register"]


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser], name: str) -> argparse.ArgumentParser:
    if name == "urdf":
        p = subparsers.add_parser(
            name, help="write the PAROL6 URDF generated from parolkit's robot model",
            description="Write the URDF of the PAROL6 (joints L1..L6 in parolkit's joint convention, "
            "limits in rad, velocity limits in rad/s, simple visual geometry) to a file or stdout.")
        p.add_argument("-o", "--output", type=Path, default=None, metavar="FILE", help="write here (default: stdout)")
        p.add_argument("--tool", default=None, help="tool at link 'tcp' (default: the original commander's TCP)")
        p.add_argument("--config", type=Path, default=None, help="parolkit.toml to use (robot model, user tools)")
        p.set_defaults(func=_run_urdf)
        return p
    p = subparsers.add_parser(
        name, help="bridge a controller to ROS 2 (DDS): /joint_states, /robot_description, /joint_trajectory",
        description="A ROS 2 node without ROS: publishes /joint_states, /robot_description, /tf and "
        "/parolkit_status from a running controller's status and executes trajectory_msgs/JointTrajectory "
        "messages from /<ns>/joint_trajectory through the controller. Needs `pip install 'parolkit[ros2]'`.")
    p.add_argument("--connect", metavar="HOST:PORT", type=parse_host_port, default=("127.0.0.1", 5001),
                   help="the controller (default 127.0.0.1:5001)")
    p.add_argument("--domain", type=int, default=None,
                   help="DDS domain (default: [ros2] domain in the config file, else $ROS_DOMAIN_ID, else 0)")
    p.add_argument("--frame-prefix", default="", metavar="PREFIX",
                   help="prefix of every robot frame on /tf and /tf_static, e.g. parol6/ (default: none, the "
                   "URDF's link names)")
    p.add_argument("--namespace", default=None, help="ROS namespace of the topics (default from config: none)")
    p.add_argument("--config", type=Path, default=None, help="parolkit.toml to use")
    p.set_defaults(func=_run_ros2)
    return p


def parse_host_port(text: str) -> tuple[str, int]:
    """``HOST:PORT`` -> (host, port), else an argparse error naming the problem."""
    host, sep, port = text.rpartition(":")
    if not sep or not host:
        raise argparse.ArgumentTypeError(f"--connect needs HOST:PORT (e.g. 127.0.0.1:5001), got {text!r}")
    if not port.isdigit() or not 1 <= int(port) <= 65535:
        raise argparse.ArgumentTypeError(f"--connect port must be an integer 1..65535, got {port!r}")
    return host.strip("[]"), int(port)


def _run_urdf(args: argparse.Namespace) -> int:
    from parolkit.config import load_config
    from parolkit.ros2.urdf import make_urdf

    try:
        cfg = load_config(args.config)
        text = make_urdf(cfg.robot, args.tool, config=cfg)
    except ParolkitError as exc:
        print(f"parolkit urdf: {exc}", file=sys.stderr)
        return 2
    if args.output is None:
        sys.stdout.write(text)
    else:
        args.output.write_text(text, encoding="utf-8")
    return 0


def _run_ros2(args: argparse.Namespace) -> int:
    from parolkit.config import load_config

    try:
        cfg = load_config(args.config, overrides={"ros2": {"domain": args.domain, "namespace": args.namespace}})
    except ParolkitError as exc:
        print(f"parolkit ros2: {exc}", file=sys.stderr)
        return 2
    try:
        from parolkit.ros2.bridge import run_bridge
    except ModuleNotFoundError as exc:
        if exc.name == "cyclonedds":
            print("parolkit ros2: needs the cyclonedds package: pip install 'parolkit[ros2]'", file=sys.stderr)
            return 2
        raise
    host, port = args.connect
    return run_bridge(cfg, host, port, domain_flag=args.domain, frame_prefix=args.frame_prefix)
