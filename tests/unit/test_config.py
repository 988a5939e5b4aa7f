"""One config object: defaults < TOML file < CLI overrides; typos are errors, never ignored."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import pytest

from parolkit.config import Config, load_config
from parolkit.errors import ParolkitValueError


def test_defaults_are_the_stock_setup():
    cfg = load_config(search_default_paths=False)
    assert cfg.controller.rate_hz == 100 and cfg.controller.udp_port == 5001
    assert cfg.controller.ack_port == 5002 and cfg.controller.bind == "127.0.0.1"
    assert cfg.serial.simulated and cfg.serial.baud == 3_000_000
    assert cfg.robot.max_speed_steps_s[0] == 6500


def test_toml_file_then_overrides(tmp_path):
    f = tmp_path / "parolkit.toml"
    f.write_text(
        """
[robot]
max_speed_steps_s = [15000, 25000, 32000, 10000, 10000, 27000]
[controller]
rate_hz = 250
udp_port = 6001
[serial]
port = "/dev/ttyACM0"
[tools.pen]
pose = [0, 0, 120, 0, 0, 0]
"""
    )
    cfg = load_config(f, {"controller": {"udp_port": 7001, "bind": None}})
    assert cfg.source == str(f)
    assert cfg.robot.max_speed_steps_s == (15000, 25000, 32000, 10000, 10000, 27000)
    assert cfg.controller.rate_hz == 250 and cfg.controller.udp_port == 7001
    assert cfg.controller.bind == "127.0.0.1"  # None override = not given
    assert cfg.serial.port == "/dev/ttyACM0" and not cfg.serial.simulated
    assert cfg.tools[0].name == "pen" and cfg.tools[0].pose == (0, 0, 120, 0, 0, 0)


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("[controler]\nrate_hz = 5", r"unknown section \[controler\]"),
        ("[controller]\nrate = 5", "unknown key controller.rate"),
        ("[controller]\nrate_hz = 0", r"controller.rate_hz must be a number in \(0, 1000\]"),
        ("[controller]\nudp_port = 70000", "controller.udp_port must be an integer in 1..65535"),
        ("[controller]\nhome_on_start = 1", "home_on_start must be true or false"),
        ("[controller]\nunhomed_jog_travel_deg = 0",
         r"controller.unhomed_jog_travel_deg must be a number in \(0, 360\]"),
        ("[robot]\ngear_ratios = [1, 2]", "gear_ratios must have 6 values"),
        ("[tools.x]\npose = [1, 2]", "tools.x.pose must be 6 finite numbers"),
        ("[tools.x]\nposition = [1, 2, 3, 4, 5, 6]", "tools.x needs exactly one key: pose"),
        ("this is = not toml [", "not valid TOML"),
        # limits tables can be narrowed, never widened or malformed
        ("[robot]\nlimits_deg = [[-200, 200], [-145, -4], [108, 287], [-105, 105], [-90, 90], [0, 360]]",
         r"limits_deg: J1 \(-200, 200\) must lie inside the published range"),
        ("[robot]\nlimits_steps = [[-14000, 14000], [-51558, -1200], [34699, 92604], [-7500, 7500], [-6400, 6400], "
         "[0, 64000.5]]", "limits_steps: J6 must be two whole numbers"),
        ("[robot]\nstandby_deg = [90, -90, 180, 0, 0, 400]", r"standby_deg: J6 = 400 is outside the joint's limits"),
        ("[robot]\nmax_jog_speed_steps_s = [7000, 3000, 3600, 7000, 7000, 18000]",
         r"J1 speeds must satisfy .* max_jog_speed_steps_s \(7000\) <= max_speed_steps_s"),
        ("[robot]\ngear_ratios = [6.4, true, 18, 4, 4, 10]", "gear_ratios: J2 must be a finite number, got True"),
        ("[tools.pen]\npose = 5", "tools.pen.pose must be 6 finite numbers"),
    ],
)
def test_bad_config_files_name_the_problem(tmp_path, text, fragment):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(ParolkitValueError, match=fragment):
        load_config(f)


def test_missing_config_file_is_an_error(tmp_path):
    with pytest.raises(ParolkitValueError, match="does not exist"):
        load_config(tmp_path / "nope.toml")


def test_config_is_immutable_and_overrides_make_copies():
    cfg = Config()
    faster = cfg.with_overrides({"controller": {"rate_hz": 250.0}})
    assert cfg.controller.rate_hz == 100 and faster.controller.rate_hz == 250
    with pytest.raises(dataclasses.FrozenInstanceError):
        cfg.controller.rate_hz = 5  # type: ignore[misc]


@pytest.mark.parametrize("port, rate, fragment", [
    ("sim://?clock=virtual&step=0.004", 100.0, r"step must be the control period, 1/100 Hz = 0.01 s, got 0.004"),
    ("sim://?step=0.01", 100.0, "step .* needs clock=virtual"),
])
def test_a_lockstep_simulated_board_must_step_the_control_period(port, rate, fragment):
    with pytest.raises(ParolkitValueError, match=fragment):
        Config().with_overrides({"serial": {"port": port}, "controller": {"rate_hz": rate}})
    ok = Config().with_overrides({"serial": {"port": "sim://?clock=virtual&step=0.004"},
                                  "controller": {"rate_hz": 250}})
    assert ok.serial.simulated


# ------------------------------------------------------------- every key has a documented range

CONFIG_DOC = Path(__file__).resolve().parents[2] / "docs" / "config.md"
_ROW = re.compile(r"^\| `([A-Za-z0-9_.]+)` \| (.*?) \| (.*) \|$")


def _documented() -> dict[str, str]:
    """``section.key`` -> its "allowed" column, from the tables of docs/config.md."""
    rows = {}
    for line in CONFIG_DOC.read_text(encoding="utf-8").splitlines():
        m = _ROW.match(line)
        if m:
            rows[m.group(1)] = m.group(3)
    return rows


def test_every_config_key_is_documented_with_its_range():
    from parolkit.collision.shapes import _TOOL_SHAPE_KEYS, _ZONE_KEYS
    from parolkit.config import _SECTIONS, _robot_fields

    keys = {f"robot.{k}" for k in _robot_fields()} | {"tools.NAME.pose", "tools.NAME.shape"}
    keys |= {f"tools.NAME.shape.{k}" for k in _TOOL_SHAPE_KEYS}
    keys |= {f"zones.{k}" for kind_keys in _ZONE_KEYS.values() for k in kind_keys}  # [[zones]]: every kind's keys
    for section, cls in _SECTIONS.items():
        keys |= {f"{section}.{f.name}" for f in dataclasses.fields(cls)}
    documented = _documented()
    assert sorted(keys - set(documented)) == [], "keys missing from docs/config.md"
    assert sorted(set(documented) - keys) == [], "docs/config.md documents keys that do not exist"


def _outside(allowed: str) -> list[float] | None:
    """Two values just outside the first range written in ``allowed`` (None: no numeric range)."""
    if m := re.match(r"(-?\d+)\.\.(\d+)", allowed):
        return [int(m.group(2)) + 1, int(m.group(1)) - 1]
    if m := re.search(r"([(\[])(-?[\d.]+), (-?[\d.]+)\]", allowed):
        lo, hi = float(m.group(2)), float(m.group(3))
        return [hi + 1, lo if m.group(1) == "(" else lo - 1]
    return None


def _bad_values(key: str, allowed: str) -> list[object]:
    cfg = Config()
    section, _, name = key.partition(".")
    if key == "tools.NAME.pose":
        return [[v, 0, 0, 0, 0, 0] for v in _outside(allowed) or []]
    if m := re.match(r"\[low, high\], 0 < low <= high <= (\d+)", allowed):
        return [[1, int(m.group(1)) + 1], [0, 1]]
    default = getattr(cfg.robot if section == "robot" else getattr(cfg, section), name)
    outside = _outside(allowed)
    if outside is None:
        return []
    if " each" in allowed:  # a per-joint list: J1 out of range
        base = list(default) if default is not None else [1000] * 6
        return [[v, *base[1:]] for v in outside]
    if isinstance(default, bool) or not isinstance(default, (int, float)):
        return []  # a range of characters (secret, password), not of values
    return outside


def _toml(value: object) -> str:
    if isinstance(value, str):
        return '"' + value + '"'
    return repr(value).replace("(", "[").replace(")", "]")


#: a valid zone of each kind, in TOML, and which kind holds each key of a [[zones]] table
_ZONE_TOML = {
    "box": {"name": "z", "kind": "box", "center": [0, 300, 500], "size": [10, 10, 10]},
    "plane": {"name": "z", "kind": "plane", "point": [0, 0, -100], "normal": [0, 0, 1]},
    "cylinder": {"name": "z", "kind": "cylinder", "center": [0, 300, 500], "axis": [0, 0, 1], "radius": 10,
                 "height": 10},
}
_ZONE_KEY_KIND = {"point": "plane", "normal": "plane", "axis": "cylinder", "radius": "cylinder",
                  "height": "cylinder"}


def _bad_files(key: str, allowed: str) -> list[str] | None:
    """TOML files with a value of a ``[[zones]]`` or ``tools.NAME.shape`` key just outside its
    documented range (the rest valid); None for the other keys."""
    section, _, name = key.partition(".")
    outside = _outside(allowed) or []
    if section == "zones":
        base = _ZONE_TOML[_ZONE_KEY_KIND.get(name, "box")]
        if name == "name":  # 1..64 characters: none, and one too many
            values: list[object] = ["a" * n for n in outside]
        elif name == "kind":
            values = ["sphere"]
        elif name == "enabled":
            values = ["yes"]
        elif "a direction" in allowed:
            values = [[0, 0, 0]]
        elif "[x, y, z]" in allowed or "[roll, pitch, yaw]" in allowed:
            values = [[v, 1, 1] for v in outside]
        else:
            values = list(outside)
        return ["[[zones]]\n" + "".join(f"{k} = {_toml(value if k == name else v)}\n"
                                         for k, v in {**base, name: None}.items()) for value in values]
    if key.startswith("tools.NAME.shape"):
        sub = key.removeprefix("tools.NAME.shape").lstrip(".")
        if not sub:
            shapes = ["5"]
        elif sub == "kind":
            shapes = ['{ kind = "cone", radius = 5 }']
        elif sub == "radius":
            shapes = [f"{{ radius = {v} }}" for v in outside] + ["{ kind = \"capsule\" }"]
        else:
            shapes = [f"{{ radius = 5, {sub} = {_toml([v, 0, 0])} }}" for v in outside]
        return [f"[tools.pen]\npose = [0, 0, 100, 0, 0, 0]\nshape = {shape}\n" for shape in shapes]
    return None


def test_the_valid_zones_and_tool_shape_the_range_test_starts_from_load(tmp_path):
    f = tmp_path / "parolkit.toml"
    for zone in _ZONE_TOML.values():
        f.write_text("[[zones]]\n" + "".join(f"{k} = {_toml(v)}\n" for k, v in zone.items()))
        assert [z.name for z in load_config(f).zones] == ["table", "z"]
    f.write_text("[tools.pen]\npose = [0, 0, 100, 0, 0, 0]\nshape = { radius = 5, start = [1, 0, 0] }\n")
    shape = load_config(f).tools[0].shape
    assert shape is not None and shape.radius == 5 and shape.start == (1, 0, 0) and shape.end == (0, 0, 100)


@pytest.mark.parametrize("key", sorted(_documented()))
def test_values_beyond_each_documented_range_are_refused_naming_the_key(tmp_path, key):
    allowed = _documented()[key]
    f = tmp_path / "parolkit.toml"
    files = _bad_files(key, allowed)
    if files is not None:
        assert files, key
        for text in files:
            f.write_text(text)
            with pytest.raises(ParolkitValueError) as info:
                load_config(f)
            assert key.rpartition(".")[2] in str(info.value) and str(f) in str(info.value), (text, str(info.value))
        return
    bad = _bad_values(key, allowed)
    if not bad:
        assert not re.search(r"\d\.\.\d|[(\[]-?\d", allowed) or "characters" in allowed, (key, allowed)
        return
    section, _, name = key.partition(".")
    for value in bad:
        if section == "tools":
            f.write_text(f"[tools.pen]\npose = {_toml(value)}\n")
        else:
            f.write_text(f"[{section}]\n{name} = {_toml(value)}\n")
        with pytest.raises(ParolkitValueError) as info:
            load_config(f)
        assert key.rpartition(".")[2] in str(info.value) and str(f) in str(info.value), (value, str(info.value))


def test_a_speed_above_the_firmwares_ceiling_is_refused_at_load_time(tmp_path):
    # once accepted: a move then ran J1 at 50,000 steps/s, 7.7x its maximum
    f = tmp_path / "parolkit.toml"
    f.write_text("[robot]\nmax_speed_steps_s = [1e12, 18000, 20000, 22000, 22000, 22000]\n")
    with pytest.raises(ParolkitValueError, match=r"max_speed_steps_s: J1 = 1e\+12 steps/s is out of range "
                                                 r"\(0, 50000\] steps/s \(the firmware clamps every joint"):
        load_config(f)
    f.write_text("[robot]\nmax_accel_steps_s2 = [19500, 54000, 60000, 66000, 66000, 1e9]\n")
    with pytest.raises(ParolkitValueError, match=r"max_accel_steps_s2: J6 = 1e\+09 steps/s\^2 is out of range"):
        load_config(f)
    f.write_text("[robot]\nmax_speed_steps_s = [inf, 18000, 20000, 22000, 22000, 22000]\n")
    with pytest.raises(ParolkitValueError, match="max_speed_steps_s: J1 must be a finite number"):
        load_config(f)
    f.write_text('[robot]\nmax_speed_steps_s = ["٨٠", 18000, 20000, 22000, 22000, 22000]\n')
    with pytest.raises(ParolkitValueError, match="max_speed_steps_s: J1 must be a finite number, got '٨٠'"):
        load_config(f)
    # the community's faster table is inside the ceiling
    f.write_text("[robot]\nmax_speed_steps_s = [15000, 25000, 32000, 10000, 10000, 27000]\n")
    assert load_config(f).robot.max_speed_steps_s[2] == 32000


def test_a_config_file_that_is_not_utf8_text_or_is_a_folder_is_refused_naming_it(tmp_path):
    f = tmp_path / "parolkit.toml"
    f.write_bytes(b"\xff\xfe[robot]\n")
    with pytest.raises(ParolkitValueError, match=r"parolkit.toml: not a TOML file: byte 0xFF at position 0 "
                                                 r"is not UTF-8 text"):
        load_config(f)
    with pytest.raises(ParolkitValueError, match="is a folder, not a TOML file"):
        load_config(tmp_path)
