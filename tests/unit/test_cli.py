"""The `parolkit` command dispatcher."""

from __future__ import annotations

import subprocess
import sys

from parolkit.cli import SUBCOMMANDS, main


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "parolkit", *args], capture_output=True, text=True, timeout=60
    )


def test_help_lists_every_sub_command():
    out = run("--help")
    assert out.returncode == 0
    for name in SUBCOMMANDS:
        assert name in out.stdout


def test_unknown_sub_command_is_an_error_listing_the_choices():
    out = run("frobnicate")
    assert out.returncode == 2
    assert "invalid choice: 'frobnicate'" in out.stderr and "serve" in out.stderr


def test_no_arguments_prints_help_and_fails(capsys):
    assert main([]) == 2
    assert "COMMAND" in capsys.readouterr().out


def test_version():
    out = run("--version")
    assert out.returncode == 0 and out.stdout.startswith("parolkit ")
