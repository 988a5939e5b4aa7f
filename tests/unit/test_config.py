"""One config object: defaults < TOML file < CLI overrides; typos are errors, never ignored."""

from __future__ import annotations

import dataclasses

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
