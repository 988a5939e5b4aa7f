"""Transport URLs: the grammar, where each option goes, clear errors, building the chain."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from parolkit.errors import ParolkitValueError
from parolkit.protocol import BoardCommand, CommandFrame, StatusParser
from parolkit.transport import (
    EmulatorTransport,
    FaultyTransport,
    SerialTransport,
    SpyTransport,
    TransportError,
    TransportURLError,
    open_transport,
    parse_transport_url,
    transport_for_url,
)
from parolkit.transport.schemes import SCHEMES

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("url, schemes, device, keywords", [
    ("sim://", ("sim",), None, [{}]),
    ("SIM://?speedup=20&clock=virtual&homed=1&pass_hz=4000", ("sim",), None,
     [{"homing_speedup": 20.0, "clock": "virtual", "start_homed": True, "pass_hz": 4000}]),
    ("/dev/ttyACM0", ("serial",), "/dev/ttyACM0", [{}]),
    ("COM3?baud=115200", ("serial",), "COM3", [{"baud": 115200}]),
    ("serial:///dev/ttyACM0?baud=3000000&write_timeout=0.5&exclusive=off", ("serial",),
     "/dev/ttyACM0", [{"baud": 3_000_000, "write_timeout_s": 0.5, "exclusive": False}]),
    ("serial:///tmp/my%20board", ("serial",), "/tmp/my board", [{}]),
    ("faulty+sim://?drop=0.01&flip=0.001", ("faulty", "sim"), None,
     [{"drop_rate": 0.01, "corrupt_rate": 0.001}, {}]),
    ("faulty+sim://?delay=0.02&silent&seed=7&speedup=5", ("faulty", "sim"), None,
     [{"delay_s": 0.02, "silent": True, "seed": 7}, {"homing_speedup": 5.0}]),
    ("spy+/dev/ttyACM0?log=frames.log", ("spy", "serial"), "/dev/ttyACM0",
     [{"log": "frames.log"}, {}]),
    ("spy+faulty+serial:///tmp/p6?log=/tmp/a%26b.log&raw=yes&drop=0&baud=9600",
     ("spy", "faulty", "serial"), "/tmp/p6",
     [{"log": "/tmp/a&b.log", "raw": True}, {"drop_rate": 0.0}, {"baud": 9600}]),
    ("faulty+spy+sim://?", ("faulty", "spy", "sim"), None, [{}, {}, {}]),
])
def test_urls_parse_into_layers_with_each_option_on_the_scheme_that_owns_it(
        url: str, schemes: tuple[str, ...], device: str | None,
        keywords: list[dict[str, object]]) -> None:
    parsed = parse_transport_url(url)
    assert parsed.schemes == schemes
    assert parsed.device == device
    assert [layer.keywords() for layer in parsed.layers] == keywords
    assert parsed.simulated is (schemes[-1] == "sim")
    again = parse_transport_url(str(parsed))  # the canonical form parses to the same
    assert again.schemes == parsed.schemes and again.device == parsed.device
    assert [la.options for la in again.layers] == [la.options for la in parsed.layers]


@pytest.mark.parametrize("url, message", [
    ("", r"empty transport URL; links: sim://, serial:// or a device path .*wrappers: faulty\+, spy\+"),
    ("   ", "empty transport URL"),
    ("tcp://host:5000", r"unknown transport scheme 'tcp://'.*links: sim://, serial://"),
    ("foo+sim://", r"unknown wrapper 'foo\+'.*wrappers: faulty\+, spy\+"),
    ("sim+spy://", r"sim:// is a link, not a wrapper: it must come last"),
    ("spy://", r"spy is a wrapper: write spy\+LINK"),
    ("spy+", r"no link after 'spy\+'"),
    ("?baud=3", r"no link before '\?'"),
    ("spy+spy+sim://", r"wrapper spy\+ appears twice"),
    ("sim://board", r"sim:// takes no path \(got 'board'\)"),
    ("serial://?baud=9600", r"serial:// needs a device"),
    ("sim:", r"write sim:// \(with two slashes\)"),
    ("sim://?bogus=1", r"unknown option 'bogus'.*options of 'sim://': speedup, clock, step, homed, pass_hz"),
    ("sim://?homing_speedup=3", r"unknown option 'homing_speedup'.*did you mean 'speedup'"),
    ("sim://?baud=9600", r"option 'baud' belongs to serial://, which 'sim://\?baud=9600' does not use"),
    ("/dev/x?drop=0.1", r"option 'drop' belongs to faulty\+.*options of 'serial://': baud, "
                        r"write_timeout, exclusive"),
    ("faulty+sim://?drop=2", r"faulty\+ option drop='2' is not allowed: expected 0\.\.1 "),
    ("faulty+sim://?flip=x", r"option flip='x' is not allowed: expected 0\.\.1"),
    ("faulty+sim://?delay=nan", r"option delay='nan' is not allowed: expected 0\.\.10 s"),
    ("faulty+sim://?seed=-1", r"option seed='-1' is not allowed: expected 0\.\.4294967295"),
    ("faulty+sim://?drop", r"option 'drop' needs a value \(drop=0\.\.1\)"),
    ("faulty+sim://?silent=maybe", r"option silent='maybe' is not allowed: expected 1\|0"),
    ("sim://?clock=fast", r"option clock='fast' is not allowed: expected realtime\|virtual"),
    ("sim://?speedup=0.5", r"option speedup='0.5' is not allowed: expected 1\.\.1000"),
    ("/dev/x?baud=3e6", r"option baud='3e6' is not allowed: expected 300\.\.12000000"),
    ("spy+sim://?log=", r"spy\+ option log='' is not allowed: expected a file path"),
    ("sim://?speedup=2&speedup=3", r"option 'speedup' appears twice"),
    ("sim://?=3", r"an option without a name"),
])
def test_bad_urls_raise_a_transport_url_error_that_says_what_is_wrong(url: str, message: str) -> None:
    with pytest.raises(TransportURLError, match=message) as info:
        parse_transport_url(url)
    # one error class that every caller's except clause sees
    assert isinstance(info.value, TransportError) and isinstance(info.value, ParolkitValueError)
    assert isinstance(info.value, ValueError)


def test_a_non_string_url_is_refused_by_name() -> None:
    with pytest.raises(TransportURLError, match="must be a string, got int"):
        parse_transport_url(3)  # type: ignore[arg-type]


def test_overrides_replace_the_url_and_must_name_a_scheme_of_the_url() -> None:
    parsed = parse_transport_url("faulty+sim://?drop=0.5&speedup=2")
    new = parsed.with_options({"drop": 0.25, "homing_speedup": 30, "clock": "virtual", "seed": None})
    assert new.layer("faulty").keywords() == {"drop_rate": 0.25}  # type: ignore[union-attr]
    assert new.base.keywords() == {"homing_speedup": 30.0, "clock": "virtual"}
    assert parsed.layer("faulty").options == {"drop": 0.5}  # type: ignore[union-attr]
    with pytest.raises(TransportURLError, match="option 'baud' belongs to serial://"):
        parsed.with_options({"baud": 9600})
    with pytest.raises(TransportURLError, match="unknown transport option 'bogus'"):
        parsed.with_options({"bogus": 1})
    with pytest.raises(TransportURLError, match="given twice"):
        parsed.with_options({"speedup": 3, "homing_speedup": 4})
    with pytest.raises(TransportURLError, match=r"option drop=True is not allowed"):
        parsed.with_options({"drop": True})
    assert new.with_options({"drop": "0.125"}).layer("faulty").options == {"drop": 0.125}  # type: ignore[union-attr]


def test_defaults_fill_gaps_only_and_are_skipped_for_schemes_not_in_the_url() -> None:
    defaults = {"baud": 115200, "speedup": 20, "write_timeout_s": 0.2}
    sim = parse_transport_url("sim://?speedup=5").with_options(defaults=defaults)
    assert sim.base.keywords() == {"homing_speedup": 5.0}
    serial = parse_transport_url("/dev/x").with_options({"baud": 9600}, defaults)
    assert serial.base.keywords() == {"baud": 9600, "write_timeout_s": 0.2}
    with pytest.raises(TransportURLError, match="unknown transport option 'bad'"):
        parse_transport_url("sim://").with_options(defaults={"bad": 1})
    with pytest.raises(TransportURLError, match="speedup=0 is not allowed"):
        parse_transport_url("sim://").with_options(defaults={"speedup": 0})


def test_get_returns_the_effective_value_of_an_option() -> None:
    url = parse_transport_url("faulty+sim://?drop=0.5").with_options(
        defaults={"speedup": 20, "baud": 9600})
    assert url.get("speedup") == 20.0 and url.get("homing_speedup") == 20.0
    assert url.get("drop") == 0.5
    assert url.get("flip", 0.0) == 0.0  # not given: the default asked for
    assert url.get("baud", "n/a") == "n/a"  # no serial link in this URL
    assert url.get("bogus") is None


def test_transport_for_url_builds_the_chain_outermost_first_without_opening_it(tmp_path: Path) -> None:
    log = tmp_path / "f.log"
    t = transport_for_url(f"spy+faulty+sim://?log={log}&drop=0.5&seed=3&clock=virtual&speedup=7")
    assert isinstance(t, SpyTransport) and not t.is_open and t.log_target == str(log)
    assert isinstance(t.inner, FaultyTransport) and t.inner.faults.drop_rate == 0.5
    assert isinstance(t.inner.inner, EmulatorTransport)
    assert t.inner.inner.emulator.homing_speedup == 7.0
    assert t.description == "spy+faulty+emulated board" and t.simulated
    assert not log.exists()  # nothing opened yet

    s = transport_for_url("serial:///dev/ttyX?baud=9600&write_timeout=0.5&exclusive=0")
    assert isinstance(s, SerialTransport) and (s.port, s.baud, s.write_timeout_s, s.exclusive) == (
        "/dev/ttyX", 9600, 0.5, False)
    assert s.description == "/dev/ttyX @ 9600" and not s.simulated


def test_open_transport_keeps_the_old_call_forms() -> None:
    t = open_transport(None, homing_speedup=5, clock="virtual")
    try:
        assert isinstance(t, EmulatorTransport) and t.is_open and t.emulator.homing_speedup == 5.0
        t.write(CommandFrame(command=BoardCommand.ENABLE).encode())
        assert [f.xtr for f in StatusParser().feed(t.read())] == [101]
    finally:
        t.close()
    s = transport_for_url("/dev/ttyY", baud=1_000_000, write_timeout_s=0.05)
    assert isinstance(s, SerialTransport) and (s.baud, s.write_timeout_s) == (1_000_000, 0.05)
    with pytest.raises(TransportError, match="cannot open serial port /nonexistent/ttyPAROL"):
        open_transport("/nonexistent/ttyPAROL")


def test_allowed_schemes_refuses_other_links_before_anything_is_built() -> None:
    with pytest.raises(TransportURLError, match=r"uses spy, which is not allowed here \(allowed: serial\)"):
        open_transport("spy+/dev/x?log=/tmp/evil", allowed_schemes={"serial"})
    t = transport_for_url("serial:///dev/x", allowed_schemes=["serial", "sim"])
    assert isinstance(t, SerialTransport)


def test_parsing_a_url_imports_neither_pyserial_nor_the_emulator_nor_numpy() -> None:
    code = ("import sys; from parolkit.transport import parse_transport_url; "
            "parse_transport_url('spy+faulty+serial:///dev/x?baud=9600&drop=0.1&log=-'); "
            "heavy = [m for m in sys.modules if m.split('.')[0] in ('serial', 'numpy') "
            "or m.startswith(('parolkit.board', 'parolkit.protocol'))]; print(heavy)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=REPO)
    assert out.stdout.strip() == "[]"



def test_config_serial_port_takes_a_url_and_reports_a_bad_one_at_load_time(tmp_path: Path) -> None:
    from parolkit.config import SerialSettings, load_config

    assert SerialSettings(port="sim://?speedup=50").simulated
    assert SerialSettings(port="spy+faulty+sim://?log=-").simulated
    assert not SerialSettings(port="spy+/dev/ttyACM0?log=frames.log").simulated
    assert not SerialSettings(port="COM3").simulated
    f = tmp_path / "parolkit.toml"
    f.write_text('[serial]\nport = "faulty+sim://?drop=5"\n')
    with pytest.raises(ParolkitValueError,
                       match=r"\[serial\]: serial.port: faulty\+ option drop='5' is not allowed"):
        load_config(f)
    with pytest.raises(ParolkitValueError, match="serial.port must be a device path .* or a transport URL"):
        SerialSettings(port=" ")


def test_docs_list_every_scheme_and_option() -> None:
    doc = (REPO / "docs" / "transport.md").read_text()
    for scheme in SCHEMES.values():
        assert f"`{scheme.prefix}" in doc, scheme.prefix
        for opt in scheme.options:
            assert re.search(rf"^\| `{opt.name}` \|", doc, re.M), f"{scheme.prefix} {opt.name}"
