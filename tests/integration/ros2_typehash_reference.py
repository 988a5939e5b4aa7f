"""ROS 2 Jazzy's own type hashes of .msg definitions (run with the ROS test venv's python, NOT
parolkit's): the reference tests/integration/test_ros2_graph.py holds parolkit.ros2.typehash to.

Reads one JSON object on stdin, ``{"pkg/msg/Name": ".msg text", ...}``; for each package
converts its .msg files to .idl with rosidl_adapter and runs rosidl_generator_type_description
(what ``colcon build`` runs), with the installed packages' type descriptions (the wheels'
``<venv>/share/<pkg>/msg/*.json``) for the types they refer to; writes ``{"pkg/msg/Name":
"RIHS01_..."}`` on stdout.  Packages are generated in dependency order (a package whose types
refer to another one given here comes after it).
"""

from __future__ import annotations

import contextlib
import json
import sys
import tempfile
from pathlib import Path

from rosidl_adapter.msg import convert_msg_to_idl
from rosidl_generator_type_description import generate_type_hash


def main() -> None:
    defs: dict[str, str] = json.load(sys.stdin)
    by_pkg: dict[str, dict[str, str]] = {}
    for name, text in defs.items():
        pkg, _, short = name.split("/")
        by_pkg.setdefault(pkg, {})[short] = text
    out: dict[str, str] = {}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        generated: dict[str, Path] = {}
        pending = list(by_pkg)
        while pending:
            # a package whose definitions mention another pending package waits for it
            ready = [p for p in pending
                     if not any(f"{q}/" in t for q in pending if q != p for t in by_pkg[p].values())]
            if not ready:
                raise SystemExit(f"packages refer to each other: {pending}")
            for pkg in ready:
                pending.remove(pkg)
                src = root / "src" / pkg
                (src / "msg").mkdir(parents=True)
                idl_dir = root / "idl" / pkg
                for short, text in by_pkg[pkg].items():
                    (src / "msg" / f"{short}.msg").write_text(text)
                    with contextlib.redirect_stdout(sys.stderr):  # it reports each file on stdout
                        convert_msg_to_idl(src, pkg, Path("msg") / f"{short}.msg", idl_dir / "msg")
                includes = [f"{p}:{d}" for p, d in generated.items()]
                for dep in ("builtin_interfaces", "std_msgs", "geometry_msgs", "sensor_msgs",
                            "trajectory_msgs", "rmw_dds_common"):
                    if dep != pkg and dep not in generated:
                        includes.append(f"{dep}:{Path(sys.prefix) / 'share' / dep}")
                out_dir = root / "out" / pkg
                args = {"package_name": pkg, "output_dir": str(out_dir),
                        "idl_tuples": [f"{idl_dir}:msg/{short}.idl" for short in by_pkg[pkg]],
                        "include_paths": includes}
                args_file = root / f"{pkg}.json"
                args_file.write_text(json.dumps(args))
                generate_type_hash(str(args_file))
                generated[pkg] = out_dir
                for short in by_pkg[pkg]:
                    desc = json.loads((out_dir / "msg" / f"{short}.json").read_text())
                    out[f"{pkg}/msg/{short}"] = desc["type_hashes"][0]["hash_string"]
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
