"""What the move classes accept and hold, for type checkers and at run time.

``parolkit.moves`` declares each enum field once, as a :class:`~parolkit.moves.WordField`
descriptor that takes the enum or its word and holds the enum
(``profile: WordField[Profile | str | None, Profile | None]``).  The typing tests run mypy
(``--strict``) on user code against THIS checkout's ``parolkit`` (site-packages switched off,
so an installed copy cannot answer instead): the constructors take the words, the fields read
as the enums, and wrong values, missing arguments and assignments are errors.
"""

from __future__ import annotations

import dataclasses
import inspect
import pickle
import re
import textwrap
from enum import Enum

import pytest
from tests.conftest import run_mypy

import parolkit.moves as moves
from parolkit.errors import ParolkitValueError

_ENUMS = {name for name, obj in vars(moves).items() if isinstance(obj, type) and issubclass(obj, Enum)}
_MOVE_CLASSES = [obj for obj in vars(moves).values() if dataclasses.is_dataclass(obj) and isinstance(obj, type)]

#: User code that must type-check cleanly: every move with a word field, built from words and
#: from enums, and what each such field reads as.
ACCEPTED = """
    import dataclasses
    from typing import assert_type

    from parolkit.moves import (
        ArcCenterMove, ArcParamMove, BlendMove, CartAxis, CartJog, CartMove, CartRelTRFMove,
        CircleMove, Frame, HelixMove, JointMove, LineSegment, Plane, PoseMove, Profile,
        SplineMove, Tracking,
    )

    q = [0.0, -90.0, 180.0, 0.0, 0.0, 180.0]
    jm = JointMove(q, profile="trap", tracking="speed")
    assert_type(jm.profile, Profile | None)
    assert_type(jm.tracking, Tracking)
    JointMove(q, 2.0, None, None, Profile.POLY, Tracking.POSITION)
    JointMove(target_deg=q, profile=None)
    assert_type(dataclasses.replace(jm, profile="ruckig").profile, Profile | None)
    pm = PoseMove([200.0, 0.0, 300.0, 180.0, 0.0, 0.0], speed_pct=50, profile="toppra")
    assert_type(pm.profile, Profile | None)
    cm = CartMove([200.0, 0.0, 300.0, 180.0, 0.0, 0.0], tracking=Tracking.SPEED)
    assert_type(cm.tracking, Tracking)
    CartRelTRFMove([0.0, 0.0, 10.0, 0.0, 0.0, 0.0], profile="poly", tracking="position")

    jog = CartJog("trf", "rz-", 50, 1)
    assert_type(jog.frame, Frame)
    assert_type(jog.axis, CartAxis)
    CartJog(Frame.WRF, CartAxis.X_POS, speed_pct=20.0, duration_s=0.5)

    circle = CircleMove((0.0, 0.0, 0.0), 10.0, plane="xz", frame="trf", profile="trap", tracking="speed")
    assert_type(circle.plane, Plane)
    assert_type(circle.frame, Frame)
    arc = ArcCenterMove([200.0, 10.0, 300.0, 180.0, 0.0, 0.0], [200.0, 0.0, 300.0], frame="wrf")
    assert_type(arc.frame, Frame)
    ArcParamMove([200.0, 10.0, 300.0, 180.0, 0.0, 0.0], 10.0, 60.0, Frame.TRF, profile=Profile.TRAP)
    HelixMove([200.0, 0.0, 300.0], 10.0, 5.0, 20.0, frame="trf", tracking="speed")
    spline = SplineMove([[200.0, 10.0, 300.0, 180.0, 0.0, 0.0]], "wrf", profile="poly")
    assert_type(spline.profile, Profile | None)
    blend = BlendMove([LineSegment([200.0, 10.0, 300.0, 180.0, 0.0, 0.0]), circle], 2.0, frame="trf")
    assert_type(blend.frame, Frame)
    assert_type(blend.tracking, Tracking)
"""

#: User code that must NOT type-check: (line, what mypy's error on that line says).
REFUSED = [
    ("JointMove(q, profile=3)", 'Argument "profile" to "JointMove" has incompatible type "int"'),
    ("JointMove(q, tracking=None)", 'Argument "tracking" to "JointMove" has incompatible type "None"'),
    ("CartMove(q, profile=2.0)", 'Argument "profile" to "CartMove" has incompatible type "float"'),
    ("CircleMove((0.0, 0.0, 0.0), 10.0, plane=1)", 'Argument "plane" to "CircleMove" has incompatible type "int"'),
    ("CartJog(1, 'x+', 50, 1)", 'Argument 1 to "CartJog" has incompatible type "int"'),
    ("CartJog('wrf')", 'Missing positional arguments "axis", "speed_pct", "duration_s" in call to "CartJog"'),
    ("CartJog(frame='wrf', speed_pct=50, duration_s=1)", 'Missing positional argument "axis" in call to "CartJog"'),
    ("JointMove(q).profile = Profile.POLY", 'Property "profile" defined in "JointMove" is read-only'),
    ("CartJog('wrf', 'x+', 50, 1).axis = 'x-'", 'Property "axis" defined in "CartJog" is read-only'),
    ("word: str = JointMove(q).profile", 'expression has type "Profile | None", variable has type "str"'),
]
_REFUSED_HEADER = """\
from parolkit.moves import CartJog, CartMove, CircleMove, JointMove, Profile

q = [0.0, -90.0, 180.0, 0.0, 0.0, 180.0]
"""


@pytest.fixture(scope="module")
def mypy_errors(tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict[int, list[str]]]:
    """mypy --strict over the accepted and the refused user code: file -> line -> errors."""
    return run_mypy(tmp_path_factory.mktemp("moves_typing"), {
        "accepted.py": textwrap.dedent(ACCEPTED).lstrip(),
        "refused.py": _REFUSED_HEADER + "".join(f"{code}\n" for code, _ in REFUSED)})


def test_the_constructors_take_the_words_and_the_fields_read_as_the_enums(mypy_errors):
    assert mypy_errors["accepted.py"] == {}


@pytest.mark.parametrize("k", range(len(REFUSED)), ids=[code for code, _ in REFUSED])
def test_a_wrong_value_a_missing_argument_or_an_assignment_is_a_type_error(mypy_errors, k):
    code, message = REFUSED[k]
    line = _REFUSED_HEADER.count("\n") + 1 + k
    assert any(message in e for e in mypy_errors["refused.py"].get(line, [])), (code, mypy_errors["refused.py"])


def test_every_enum_field_of_every_move_is_a_parsed_field():
    with_enum = []
    for cls in _MOVE_CLASSES:
        for f in dataclasses.fields(cls):
            if any(name in _ENUMS for name in re.findall(r"\w+", str(f.type))):
                with_enum.append(f"{cls.__name__}.{f.name}")
                assert isinstance(vars(cls)[f.name], moves.WordField), f"{cls.__name__}.{f.name}"
    assert "CartJog.axis" in with_enum and "CircleMove.plane" in with_enum  # (not vacuous)


def test_the_words_are_parsed_into_the_enums_the_fields_are_typed_as():
    m = moves.CircleMove((0, 0, 0), 10, plane="xz", frame="trf", profile="TRAP", tracking="speed")
    assert (m.plane, m.frame, m.profile, m.tracking) == (
        moves.Plane.XZ, moves.Frame.TRF, moves.Profile.TRAP, moves.Tracking.SPEED)
    j = moves.CartJog("wrf", "rz-", 50, 1)
    assert (j.frame, j.axis) == (moves.Frame.WRF, moves.CartAxis.RZ_NEG)
    r = dataclasses.replace(m, profile="poly", plane=moves.Plane.YZ)
    assert (r.profile, r.plane, r.frame) == (moves.Profile.POLY, moves.Plane.YZ, moves.Frame.TRF)


def test_the_defaults_are_the_enums_and_a_jog_needs_its_frame_and_axis():
    params = inspect.signature(moves.JointMove).parameters
    assert params["profile"].default is None
    assert params["tracking"].default is moves.Tracking.POSITION
    assert inspect.signature(moves.CircleMove).parameters["plane"].default is moves.Plane.XY
    assert inspect.signature(moves.SplineMove).parameters["frame"].default is moves.Frame.WRF
    jog = inspect.signature(moves.CartJog).parameters
    assert jog["frame"].default is inspect.Parameter.empty and jog["axis"].default is inspect.Parameter.empty
    m = moves.JointMove([0] * 6)
    assert (m.profile, m.tracking) == (None, moves.Tracking.POSITION)
    with pytest.raises(TypeError, match="frame"):
        moves.CartJog()  # type: ignore[call-arg]


@pytest.mark.parametrize(("build", "message"), [
    (lambda: moves.JointMove([0] * 6, profile="fast"),
     "profile must be one of poly, trap, ruckig, toppra or None, got 'fast'"),
    (lambda: moves.CartMove([0] * 6, tracking="torque"), "tracking must be 'position' or 'speed', got 'torque'"),
    (lambda: moves.SplineMove([[0] * 6], frame="base"), "frame must be WRF or TRF, got 'base'"),
    (lambda: moves.CircleMove((0, 0, 0), 1, plane="XW"), "plane must be XY, XZ or YZ, got 'XW'"),
    (lambda: moves.CartJog("wrf", "W+", 50, 1), "axis must be one of X+, X-, Y+, Y-, Z+, Z-, RX+, RX-, RY+, RY-, "
                                                "RZ+, RZ-, got 'W+'"),
])
def test_a_bad_word_is_refused_naming_the_field_and_the_words(build, message):
    with pytest.raises(ParolkitValueError) as exc:
        build()
    assert str(exc.value) == message


def test_a_move_is_frozen_and_copies_and_pickles_as_a_plain_dataclass():
    m = moves.HelixMove((0, 0, 0), 10, 5, 20, frame="trf", profile="trap")
    assert vars(m)["frame"] is moves.Frame.TRF and vars(m)["profile"] is moves.Profile.TRAP
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.frame = moves.Frame.WRF  # type: ignore[misc]
    back = pickle.loads(pickle.dumps(m))
    assert back == m and hash(back) == hash(m) and back.frame is moves.Frame.TRF
