"""The commander's access rules without a browser: program names and the programs folder (on
the real file system, links included), the Host / Origin allow-list, the login's sessions and
failure limit, the control badge, and the [gui] config keys."""

from __future__ import annotations

import os

import pytest

from parolkit.config import GuiSettings, load_config
from parolkit.errors import ParolkitValueError
from parolkit.gui.lease_watch import Holder, describe_control, local_host_for
from parolkit.gui.programs import (
    MAX_PROGRAM_BYTES,
    ProgramNameError,
    ProgramsFolder,
    default_programs_dir,
    program_name,
)
from parolkit.gui.security import (
    FAILURE_WINDOW_S,
    MAX_FAILURES,
    AccessPolicy,
    LoginGate,
    host_name,
    is_loopback_bind,
    origin_host,
)

# ---- program names and the folder ----


@pytest.mark.parametrize("text, expected", [
    ("demo", "demo.rbt"),
    ("demo.rbt", "demo.rbt"),
    ("pick and place v2", "pick and place v2.rbt"),
    ("cell_1-A.test", "cell_1-A.test.rbt"),
    ("  spaced  ", "spaced.rbt"),
])
def test_program_names_get_the_rbt_extension(text, expected):
    assert program_name(text) == expected


@pytest.mark.parametrize("text, rule", [
    ("/etc/passwd", "is an absolute path"),
    ("~/notes", "is an absolute path"),
    ("C:\\Windows\\win.ini", "is an absolute path"),
    ("../secret", "contains a path separator"),
    ("sub/prog", "contains a path separator"),
    ("sub\\prog", "contains a path separator"),
    ("..", "contains '..'"),
    ("a..b", "contains '..'"),
    (".hidden", "starts with '.'"),
    ("prog;rm", "contains ';'"),
    ("naïve", "contains 'ï'"),
    ("x" * 120, "characters long"),
    ("", "no program name given"),
])
def test_refused_program_names_say_which_rule_they_break(text, rule):
    with pytest.raises(ProgramNameError, match=rule) as info:
        program_name(text)
    if text:
        assert "letters, digits, spaces" in str(info.value)  # the rule itself is stated


def test_the_folder_reads_and_writes_only_inside_itself(tmp_path):
    folder = ProgramsFolder(tmp_path / "programs")
    folder.create()
    assert folder.root.is_dir()
    path = folder.write("demo", "Begin()\nEnd()\n")
    assert path == (tmp_path / "programs" / "demo.rbt").resolve()
    assert folder.read("demo.rbt") == (path, "Begin()\nEnd()\n")
    (tmp_path / "programs" / "notes.txt").write_text("not a program")
    (tmp_path / "programs" / "Zeta.rbt").write_text("")
    assert folder.names() == ["demo.rbt", "Zeta.rbt"]
    outside = tmp_path / "secret.rbt"
    outside.write_text("the user's other file")
    for name in ("../secret", str(outside), "/etc/passwd"):
        with pytest.raises(ProgramNameError):
            folder.read(name)
        with pytest.raises(ProgramNameError):
            folder.write(name, "overwritten?")
    assert outside.read_text() == "the user's other file"


def test_a_link_out_of_the_folder_is_refused_and_not_listed(tmp_path):
    folder = ProgramsFolder(tmp_path / "programs")
    folder.create()
    outside = tmp_path / "private.txt"
    outside.write_text("private")
    os.symlink(outside, folder.root / "link.rbt")
    with pytest.raises(ProgramNameError, match="outside the programs folder"):
        folder.read("link")
    with pytest.raises(ProgramNameError, match="outside the programs folder"):
        folder.write("link.rbt", "overwritten?")
    assert outside.read_text() == "private"
    assert folder.names() == []
    # a link to another program inside the folder is fine
    folder.write("real", "Begin()\n")
    os.symlink(folder.root / "real.rbt", folder.root / "alias.rbt")
    assert folder.read("alias")[1] == "Begin()\n"


def test_a_too_large_program_is_refused(tmp_path):
    folder = ProgramsFolder(tmp_path)
    (tmp_path / "big.rbt").write_bytes(b"#" * (MAX_PROGRAM_BYTES + 1))
    with pytest.raises(ProgramNameError, match=f"at most {MAX_PROGRAM_BYTES} bytes"):
        folder.read("big")
    with pytest.raises(ProgramNameError, match=f"at most {MAX_PROGRAM_BYTES} bytes"):
        folder.write("big2", "#" * (MAX_PROGRAM_BYTES + 1))


def test_the_default_folder_follows_xdg_data_home(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path))
    assert default_programs_dir() == tmp_path / "parolkit" / "programs"
    monkeypatch.setenv("XDG_DATA_HOME", "relative/ignored")  # the spec: only absolute paths count
    assert default_programs_dir().parts[-4:] == (".local", "share", "parolkit", "programs")


# ---- Host / Origin ----


@pytest.mark.parametrize("header, name", [
    ("127.0.0.1:8080", "127.0.0.1"),
    ("LocalHost", "localhost"),
    ("localhost.:8080", "localhost"),
    ("[::1]:8080", "::1"),
    ("[::1]", "::1"),
    ("robot-pc.local", "robot-pc.local"),
    ("", None),
    ("::1", None),  # IPv6 needs brackets in Host
    ("evil.example:80x", None),
    ("user@127.0.0.1", None),
    ("[not-v6]:80", None),
    (None, None),
])
def test_host_header_names(header, name):
    assert host_name(header) == name


@pytest.mark.parametrize("origin, name", [
    ("http://127.0.0.1:8080", "127.0.0.1"),
    ("https://robot-pc.local", "robot-pc.local"),
    ("http://[::1]:8080", "::1"),
    ("null", None),
    ("file://", None),
    ("ftp://127.0.0.1", None),
    ("http://127.0.0.1:8080/path", None),
    ("http://user@127.0.0.1", None),
])
def test_origin_hosts(origin, name):
    assert origin_host(origin) == name


def test_the_allow_list_is_loopback_plus_the_bound_address_plus_config():
    policy = AccessPolicy.for_bind("127.0.0.1", ["Robot-PC.local", "[fd00::5]"])
    assert policy.allowed == {"localhost", "127.0.0.1", "::1", "robot-pc.local", "fd00::5"}
    assert policy.host_allowed("localhost:8080") and policy.host_allowed("ROBOT-PC.local")
    assert policy.host_allowed("[fd00::5]:8080")
    assert not policy.host_allowed("evil.example") and not policy.host_allowed(None)
    assert not policy.host_allowed("127.0.0.1.evil.example")
    assert policy.origin_allowed("http://localhost:9000")  # an SSH tunnel's port is fine
    assert not policy.origin_allowed("http://evil.example:8080")
    assert not policy.origin_allowed("null") and not policy.origin_allowed(None)


def test_bound_to_every_interface_the_machines_own_names_are_allowed():
    policy = AccessPolicy.for_bind("0.0.0.0", (), machine=lambda: {"robot-pc", "192.168.1.20"})
    assert {"robot-pc", "192.168.1.20", "localhost"} <= policy.allowed
    assert "0.0.0.0" not in policy.allowed
    policy = AccessPolicy.for_bind("192.168.1.20", (), machine=lambda: {"never-used"})
    assert "192.168.1.20" in policy.allowed and "never-used" not in policy.allowed


def test_loopback_binds():
    assert is_loopback_bind("127.0.0.1") and is_loopback_bind("localhost") and is_loopback_bind("::1")
    assert is_loopback_bind("127.0.0.2")
    assert not is_loopback_bind("0.0.0.0") and not is_loopback_bind("::")


# ---- login ----


def test_sessions_open_only_with_the_password_and_expire():
    gate = LoginGate("correct horse", lifetime_s=100.0)
    assert gate.check_password("correct horse")
    assert not gate.check_password("correct hors") and not gate.check_password("")
    assert not gate.check_password("correct horse ")
    token = gate.open_session(now=0.0)
    assert len(token) >= 40 and gate.valid(token, now=99.0)
    assert not gate.valid(token, now=100.0)
    assert not gate.valid(token + "x", now=1.0) and not gate.valid(None) and not gate.valid("")
    token2 = gate.open_session(now=200.0)
    assert token2 != token and gate.valid(token2, now=201.0)
    gate.close_session(token2)
    assert not gate.valid(token2, now=201.0)
    assert "correct horse" not in repr(gate)


def test_failed_logins_are_limited_per_client():
    gate = LoginGate("correct horse")
    for i in range(MAX_FAILURES):
        assert gate.blocked_for("10.0.0.9", now=float(i)) == 0.0
        gate.record_failure("10.0.0.9", now=float(i))
    assert gate.blocked_for("10.0.0.9", now=5.0) == pytest.approx(FAILURE_WINDOW_S - 5.0)
    assert gate.blocked_for("10.0.0.7", now=5.0) == 0.0  # another client is not affected
    assert gate.blocked_for("10.0.0.9", now=FAILURE_WINDOW_S + 0.5) == 0.0  # the oldest has aged out


# ---- the control badge ----


def _info(holder, secret=False):
    return {"holder": holder, "held_s": 1.0, "idle_s": 0.5, "timeout_s": 10.0, "secret_required": secret,
            "refused": 0, "taken_over": 0}


def test_the_badge_names_who_controls_the_robot():
    local = local_host_for("127.0.0.1")
    assert local == "127.0.0.1" and local_host_for("10.0.0.5") is None
    view = describe_control(_info("127.0.0.1:40112"), 40112, None, local)
    assert view.holder is Holder.US and view.text == "You control the robot" and not view.can_take
    view = describe_control(_info("127.0.0.1:40200"), 40112, 40200, local)
    assert view.holder is Holder.RUNNER and not view.can_take
    view = describe_control(_info("127.0.0.1:5002"), 40112, 40200, local)  # a robot_api script
    assert view.holder is Holder.OTHER and view.text == "Controlled by 127.0.0.1:5002"
    assert view.can_take
    view = describe_control(_info("10.0.0.3:40112"), 40112, None, local)  # same port, other host
    assert view.holder is Holder.OTHER
    view = describe_control(_info("10.0.0.3:40112"), 40112, None, None)  # host unknown: the port decides
    assert view.holder is Holder.US
    view = describe_control(_info(None, secret=True), 40112, None, local)
    assert view.holder is Holder.FREE and "secret required" in view.text
    assert describe_control(None, 40112, None, local).holder is Holder.UNKNOWN


# ---- config ----


def test_gui_config_keys(tmp_path):
    f = tmp_path / "parolkit.toml"
    f.write_text('[gui]\nprograms_dir = "~/progs"\nallowed_hosts = ["robot-pc.local", "192.168.1.20", "[fd00::1]"]\n'
                 'password = "correct horse"\n')
    gui = load_config(f).gui
    assert gui.programs_dir == "~/progs" and gui.password == "correct horse"
    assert gui.allowed_hosts == ("robot-pc.local", "192.168.1.20", "fd00::1")
    assert "correct horse" not in repr(gui) and "***" in repr(gui)
    defaults = GuiSettings()
    assert defaults.host == "127.0.0.1" and defaults.password is None and defaults.programs_dir is None


@pytest.mark.parametrize("text, fragment", [
    ('password = "short"', "gui.password must be 8..256 printable characters"),
    ("password = 12345678", "gui.password must be 8..256 printable characters, got a int"),
    ('allowed_hosts = "robot-pc"', "gui.allowed_hosts must be a list"),
    ('allowed_hosts = ["http://robot-pc:8080"]', "'http://robot-pc:8080' is not a host name or an IP address"),
    ('allowed_hosts = ["-bad"]', "'-bad' is not a host name"),
    ('programs_dir = ""', "gui.programs_dir must be a folder path"),
    ('host = ""', "gui.host must be a host name or address"),
    ("open_browser = 1", "gui.open_browser must be true or false"),
])
def test_bad_gui_config_names_the_key(tmp_path, text, fragment):
    f = tmp_path / "bad.toml"
    f.write_text("[gui]\n" + text + "\n")
    with pytest.raises(ParolkitValueError) as info:
        load_config(f)
    assert fragment in str(info.value)
