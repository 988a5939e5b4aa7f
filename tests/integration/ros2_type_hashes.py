"""Reference RIHS01 type hashes from ROS 2's own tools (run with the ROS test venv's python).

    python ros2_type_hashes.py PKG_DIR PKG_NAME SHARE_DIR OUT_DIR

Converts every ``.msg`` and ``.action`` under PKG_DIR (a package's interface definitions, e.g.
tests/data/control_msgs) to IDL with rosidl_adapter, runs rosidl_generator_type_description on
them (the dependencies' type descriptions from SHARE_DIR, the ROS venv's share/ directory, as
a colcon build takes them from the install space) and prints one JSON object: every type
name -> its RIHS01 hash, for the package's types and the installed ones named on stdin (one
``pkg/kind/Name`` a line).  It imports nothing of parolkit: the hashes are ROS's.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from rosidl_adapter.action import convert_action_to_idl
from rosidl_adapter.msg import convert_msg_to_idl
from rosidl_generator_type_description import generate_type_hash


def main() -> None:
    pkg_dir, pkg = Path(sys.argv[1]).resolve(), sys.argv[2]
    share, out = Path(sys.argv[3]).resolve(), Path(sys.argv[4]).resolve()
    idl_dir = out / "idl"
    tuples = []
    for kind, convert in (("msg", convert_msg_to_idl), ("action", convert_action_to_idl)):
        for src in sorted((pkg_dir / kind).glob(f"*.{kind}")):
            convert(pkg_dir, pkg, src.relative_to(pkg_dir), idl_dir / kind)
            tuples.append(f"{idl_dir}:{kind}/{src.stem}.idl")
    deps = sorted(p.name for p in share.iterdir() if any((p / k).is_dir() for k in ("msg", "srv", "action")))
    args = out / "args.json"
    args.write_text(json.dumps({"package_name": pkg, "output_dir": str(out / "json"), "idl_tuples": tuples,
                                "include_paths": [f"{d}:{share / d}" for d in deps]}))
    generate_type_hash(str(args))
    hashes: dict[str, str] = {}
    for f in sorted((out / "json").rglob("*.json")):
        for h in json.loads(f.read_text())["type_hashes"]:
            hashes[h["type_name"]] = h["hash_string"]
    for line in sys.stdin:
        name = line.strip()
        if name:
            pkg_name, kind, short = name.split("/")
            data = json.loads((share / pkg_name / kind / f"{short}.json").read_text())
            hashes.update({h["type_name"]: h["hash_string"] for h in data["type_hashes"]})
    print(json.dumps(hashes, sort_keys=True))


if __name__ == "__main__":
    main()
