"""``parolkit serve`` flag handling and the early PING responder (real UDP sockets)."""

from __future__ import annotations

import argparse
import socket

from parolkit.controller import cli
from parolkit.controller.steering import open_command_port


def _args(**kw) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers()
    cli.register(sub, "serve")
    argv = ["serve"]
    for k, v in kw.items():
        flag = "--" + k.replace("_", "-")
        argv += [flag] if v is True else [flag, str(v)]
    return parser.parse_args(argv)


def test_flags_become_config_overrides_and_unset_flags_stay_none():
    o = cli.build_overrides(_args(rate=250, udp_port=6001, no_home=True, port="/dev/ttyACM0",
                                  stream_watchdog=0.15))
    assert o["controller"]["rate_hz"] == 250 and o["controller"]["udp_port"] == 6001
    assert o["controller"]["stream_watchdog_s"] == 0.15
    assert o["controller"]["home_on_start"] is False and o["controller"]["bind"] is None
    assert o["serial"] == {"port": "/dev/ttyACM0"}


def test_early_address_reads_the_toml_and_flags_win(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text('[controller]\nudp_port = 7001\nbind = "127.0.0.2"\n')
    assert cli._early_address(_args(config=cfg)) == ("127.0.0.2", 7001)
    assert cli._early_address(_args(config=cfg, udp_port=7002, bind="127.0.0.1")) == ("127.0.0.1", 7002)
    cfg.write_text("[controller]\nudp_port = 'x'\n")
    assert cli._early_address(_args(config=cfg)) == (None, 0)  # the full loader reports it


def test_early_responder_answers_ping_and_leaves_commands_for_the_server():
    bound = open_command_port("127.0.0.1", 0)
    sock = bound.sock
    port = sock.getsockname()[1]
    early = cli.EarlyPong(bound)
    early.start()
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as c:
            c.settimeout(2.0)
            c.sendto(b"PING", ("127.0.0.1", port))
            assert c.recvfrom(100)[0] == b"PONG"
            c.sendto(b"abcd1234|HOME", ("127.0.0.1", port))
            import time

            time.sleep(0.1)
    finally:
        early.stop()
    sock.settimeout(1.0)
    assert sock.recvfrom(100)[0] == b"abcd1234|HOME"  # still queued for the real server
    early.close()
