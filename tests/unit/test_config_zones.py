"""``[[zones]]`` and ``[tools.NAME] shape`` in the config: typed zones, the table on by
default, and a precise error (the zone or tool, the field, the allowed range) for every bad value."""

from __future__ import annotations

import pytest

from parolkit.collision import TABLE_ZONE, BoxZone, CylinderZone, PlaneZone, ToolShape
from parolkit.config import Config, ToolSettings, load_config
from parolkit.errors import ParolkitValueError


def _load(tmp_path, text: str) -> Config:
    f = tmp_path / "parolkit.toml"
    f.write_text(text, encoding="utf-8")
    return load_config(f)


def test_the_table_plane_under_the_base_is_on_by_default():
    cfg = load_config(search_default_paths=False)
    assert cfg.zones == (TABLE_ZONE,)
    table = cfg.zones[0]
    assert isinstance(table, PlaneZone) and table.name == "table"
    assert table.point == (0.0, 0.0, 0.0) and table.normal == (0.0, 0.0, 1.0) and table.margin == 0.0
    assert Config().zones == (TABLE_ZONE,)


def test_zones_of_every_kind_are_read_as_typed_frozen_values(tmp_path):
    cfg = _load(tmp_path, """
[[zones]]
name = "monitor"
kind = "box"
center = [300, -250, 200]
size = [400, 60, 300]
rpy = [0, 0, 30]
margin = 10

[[zones]]
name = "wall"
kind = "plane"
point = [0, -300, 0]
normal = [0, 2, 0]
margin = 5.5

[[zones]]
name = "camera post"
kind = "cylinder"
center = [200, 200, 150]
axis = [0, 0, 1]
radius = 20
height = 300
""")
    table, monitor, wall, post = cfg.zones
    assert table == TABLE_ZONE
    assert monitor == BoxZone("monitor", (300, -250, 200), (400, 60, 300), (0, 0, 30), 10)
    assert wall == PlaneZone("wall", (0, -300, 0), (0, 2, 0), 5.5)
    assert post == CylinderZone("camera post", (200, 200, 150), (0, 0, 1), 20, 300)
    assert post.margin == 0.0 and monitor.rpy == (0.0, 0.0, 30.0)
    assert all(isinstance(v, float) for v in monitor.center)
    with pytest.raises(AttributeError):
        monitor.margin = 3  # type: ignore[misc]


def test_the_table_can_be_switched_off_or_moved(tmp_path):
    off = _load(tmp_path, '[[zones]]\nname = "table"\nenabled = false\n')
    assert off.zones == ()
    moved = _load(tmp_path, '[[zones]]\nname = "table"\nkind = "plane"\npoint = [0, 0, -12]\nnormal = [0, 0, 1]\n'
                            'margin = 2\n')
    assert moved.zones == (PlaneZone("table", (0, 0, -12), (0, 0, 1), 2),)
    # a whole definition with enabled = false is validated, then left out
    kept_off = _load(tmp_path, '[[zones]]\nname = "box"\nkind = "box"\ncenter = [0, 0, 0]\nsize = [1, 1, 1]\n'
                               'enabled = false\n')
    assert kept_off.zones == (TABLE_ZONE,)


def test_command_line_overrides_add_replace_and_switch_off_zones(tmp_path):
    cfg = _load(tmp_path, '[[zones]]\nname = "post"\nkind = "cylinder"\ncenter = [0, 300, 0]\naxis = [0, 0, 1]\n'
                          'radius = 10\nheight = 500\n')
    over = cfg.with_overrides({"zones": [{"name": "post", "enabled": False},  # type: ignore[dict-item]
                                         {"name": "b", "kind": "box", "center": [1, 2, 3], "size": [4, 5, 6]}]})
    assert [z.name for z in over.zones] == ["table", "b"]


@pytest.mark.parametrize("text, message", [
    # names and kinds
    ('[[zones]]\nkind = "box"\ncenter = [0, 0, 0]\nsize = [1, 1, 1]',
     r"\[\[zones\]\] #1: name is required"),
    ('[[zones]]\nname = "a|b"\nkind = "box"\ncenter = [0, 0, 0]\nsize = [1, 1, 1]',
     r"zone name must be 1..64 characters: letters, digits, spaces, '_', '-' or '.'.*got 'a\|b'"),
    ('[[zones]]\nname = "x"\nkind = "sphere"',
     r'zones.x.kind must be one of "box", "plane", "cylinder", got \'sphere\''),
    ('[[zones]]\nname = "x"', r'zones.x.kind must be one of "box", "plane", "cylinder", got None'),
    ('[[zones]]\nname = "x"\nkind = "box"\ncentre = [0, 0, 0]\nsize = [1, 1, 1]',
     r"zones.x: unknown key centre \(a box zone has: name, kind, center, size, rpy, margin, enabled\)"),
    ('[[zones]]\nname = "x"\nkind = "box"\ncenter = [0, 0, 0]',
     r"zones.x: a box zone needs size"),
    ('[[zones]]\nname = "x"\nkind = "cylinder"\ncenter = [0, 0, 0]\naxis = [0, 0, 1]',
     r"zones.x: a cylinder zone needs radius, height"),
    # boxes
    ('[[zones]]\nname = "x"\nkind = "box"\ncenter = [0, 0, 0]\nsize = [10, 0, 10]',
     r"zones.x.size: y = 0 mm is out of range \(0, 20000\] mm"),
    ('[[zones]]\nname = "x"\nkind = "box"\ncenter = [0, 0, 0]\nsize = [10, 10]',
     r"zones.x.size must be 3 finite numbers \[x, y, z\] in mm, got \[10, 10\]"),
    ('[[zones]]\nname = "x"\nkind = "box"\ncenter = [0, 20000, 0]\nsize = [1, 1, 1]',
     r"zones.x.center: y = 20000 mm is out of range \[-10000, 10000\] mm"),
    ('[[zones]]\nname = "x"\nkind = "box"\ncenter = [0, 0, 0]\nsize = [1, 1, 1]\nrpy = [0, 400, 0]',
     r"zones.x.rpy: pitch = 400 deg is out of range \[-360, 360\] deg"),
    ('[[zones]]\nname = "x"\nkind = "box"\ncenter = [0, 0, 0]\nsize = [1, 1, 1]\nmargin = -1',
     r"zones.x.margin must be a number in \[0, 1000\] mm, got -1"),
    ('[[zones]]\nname = "x"\nkind = "box"\ncenter = [0, 0, 0]\nsize = [1, 1, 1]\nmargin = "5"',
     r"zones.x.margin must be a number in \[0, 1000\] mm, got '5'"),
    ('[[zones]]\nname = "x"\nkind = "box"\ncenter = [0, 0, 0]\nsize = [1, 1, 1]\nenabled = 1',
     r"zones.x.enabled must be true or false, got 1"),
    ('[[zones]]\nname = "x"\nkind = "box"\ncenter = [0, nan, 0]\nsize = [1, 1, 1]',
     r"zones.x.center must be 3 finite numbers"),
    # planes
    ('[[zones]]\nname = "x"\nkind = "plane"\npoint = [0, 0, 0]\nnormal = [0, 0, 0]',
     r"zones.x.normal must be a direction: 3 finite numbers \[x, y, z\], not all 0, got \[0, 0, 0\]"),
    ('[[zones]]\nname = "x"\nkind = "plane"\npoint = [0, 0, 0]\nnormal = [0, 0, 1]\nsize = [1, 1, 1]',
     r"zones.x: unknown key size \(a plane zone has: name, kind, point, normal, margin, enabled\)"),
    # cylinders
    ('[[zones]]\nname = "x"\nkind = "cylinder"\ncenter = [0, 0, 0]\naxis = [0, 0, 1]\nradius = 0\nheight = 5',
     r"zones.x.radius must be a number in \(0, 20000\] mm, got 0"),
    ('[[zones]]\nname = "x"\nkind = "cylinder"\ncenter = [0, 0, 0]\naxis = [0, 0, 1]\nradius = 5\nheight = 1e9',
     r"zones.x.height must be a number in \(0, 20000\] mm, got 1000000000.0"),
    ('[[zones]]\nname = "x"\nkind = "cylinder"\ncenter = [0, 0, 0]\naxis = [0, 0]\nradius = 5\nheight = 5',
     r"zones.x.axis must be a direction"),
    # the list itself
    ('[zones]\nname = "x"', r"zones must be a list of tables: write each zone as \[\[zones\]\]"),
    ('[[zones]]\nname = "x"\nkind = "box"\ncenter = [0, 0, 0]\nsize = [1, 1, 1]\n'
     '[[zones]]\nname = "x"\nkind = "box"\ncenter = [0, 0, 0]\nsize = [1, 1, 1]',
     r"zones.x: two \[\[zones\]\] tables have this name \(#2 is the second\)"),
    ('[[zones]]\nname = "nothing"\nenabled = false',
     r"zones.nothing: enabled = false names no zone in force \(known: 'table'\)"),
    ('[[zones]]\nname = "table"\nenabled = true',
     r"zones.table: a zone needs kind and its shape's keys \(only enabled = false may stand alone"),
])
def test_every_bad_zone_value_is_refused_naming_the_zone_the_field_and_the_range(tmp_path, text, message):
    with pytest.raises(ParolkitValueError, match=message) as info:
        _load(tmp_path, text + "\n")
    assert str(tmp_path / "parolkit.toml") in str(info.value)


def test_zones_built_in_code_are_validated_the_same_way():
    with pytest.raises(ParolkitValueError, match=r"zones.m.size: x = -1 mm is out of range \(0, 20000\] mm"):
        BoxZone("m", (0, 0, 0), (-1, 1, 1))
    with pytest.raises(ParolkitValueError, match=r"zone name must be"):
        PlaneZone("", (0, 0, 0), (0, 0, 1))
    with pytest.raises(ParolkitValueError, match=r"zones.c.radius must be a number in \(0, 20000\] mm, got True"):
        CylinderZone("c", (0, 0, 0), (0, 0, 1), True, 5)  # type: ignore[arg-type]


def test_a_tool_may_have_a_capsule_shape_from_the_flange_to_its_tcp(tmp_path):
    cfg = _load(tmp_path, '[tools.pen]\npose = [0, 0, 120, 0, 0, 0]\nshape = { kind = "capsule", radius = 8 }\n'
                          '[tools.gripper]\npose = [0, 0, 90, 0, 0, 0]\n'
                          '[tools.gripper.shape]\nradius = 30\nstart = [0, 0, 20]\nend = [0, 0, 110]\n'
                          '[tools.bare]\npose = [0, 0, 50, 0, 0, 0]\n')
    pen, gripper, bare = cfg.tools
    assert pen.shape == ToolShape("pen", 8.0, (0.0, 0.0, 0.0), (0.0, 0.0, 120.0))
    assert gripper.shape == ToolShape("gripper", 30.0, (0.0, 0.0, 20.0), (0.0, 0.0, 110.0))
    assert bare.shape is None
    assert ToolSettings("bare", (0, 0, 50, 0, 0, 0)).shape is None


@pytest.mark.parametrize("shape, message", [
    ('{ kind = "capsule" }', r"tools.pen.shape needs radius \(mm\): the tool is a capsule from start to end"),
    ('{ kind = "box", radius = 3 }', r'tools.pen.shape.kind must be "capsule"'),
    ('{ radius = 0 }', r"tools.pen.shape.radius must be a number in \(0, 500\] mm, got 0"),
    ('{ radius = 600 }', r"tools.pen.shape.radius must be a number in \(0, 500\] mm, got 600"),
    ('{ radius = 5, end = [0, 0, 2000] }', r"tools.pen.shape.end: z = 2000 mm is out of range \[-1000, 1000\] mm"),
    ('{ radius = 5, start = [0, 0] }', r"tools.pen.shape.start must be 3 finite numbers"),
    ('{ radius = 5, length = 3 }',
     r"tools.pen.shape: unknown key length \(a tool shape has: kind, radius, start, end\)"),
    ('5', r"tools.pen.shape must be a table such as \{ kind = \"capsule\", radius = 20 \}, got 5"),
])
def test_every_bad_tool_shape_is_refused_naming_the_tool_and_the_field(tmp_path, shape, message):
    with pytest.raises(ParolkitValueError, match=message):
        _load(tmp_path, f"[tools.pen]\npose = [0, 0, 120, 0, 0, 0]\nshape = {shape}\n")


def test_a_tool_still_needs_its_pose_and_no_other_key(tmp_path):
    with pytest.raises(ParolkitValueError, match=r"tools.pen needs exactly one key: pose \(and may have a shape\), "
                                                 r"got shape"):
        _load(tmp_path, "[tools.pen]\nshape = { radius = 5 }\n")
    with pytest.raises(ParolkitValueError, match=r"tools.pen needs exactly one key: pose .*got pose, weight"):
        _load(tmp_path, "[tools.pen]\npose = [0, 0, 1, 0, 0, 0]\nweight = 5\n")
