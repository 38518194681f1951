"""Every command's --help works, and units in brackets survive (they are not rich markup)."""

from __future__ import annotations

import pytest

from liquidtouch.cli import main

COMMANDS = [
    ["fit"],
    ["extract"],
    ["features"],
    ["train"],
    ["classify"],
    ["predict"],
    ["transfer"],
    ["reproduce"],
    ["demo"],
    ["simulate", "trial"],
    ["simulate", "dataset"],
    ["simulate", "presets"],
]


@pytest.mark.parametrize("command", COMMANDS, ids=" ".join)
def test_help_of_every_command(command: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    assert main([*command, "--help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("Usage: liquidtouch " + " ".join(command))
    assert "[default: " in out or "[required]" in out or "--help" in out


def test_units_in_brackets_are_printed(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", "trial", "--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "Fill height [mm]" in out
    assert "[default: " in out


def test_shell_completion_is_offered(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--help"]) == 0
    assert "--install-completion" in capsys.readouterr().out
