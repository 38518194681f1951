"""The commands are thin: parse, call a library function, print (issue 37).

Every function of ``liquidtouch.cli`` is at most 60 lines, its signature included:
what a command computes lives in the library, where a notebook can call it, and the
option declarations are shared ``Annotated`` aliases.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from liquidtouch.cli.flags import PARAMETER_FLAGS, name_flags

CLI = Path(__file__).resolve().parents[2] / "src" / "liquidtouch" / "cli"
MAX_LINES = 60


def _functions() -> list[tuple[str, int]]:
    found = []
    for path in sorted(CLI.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                found.append((f"{path.name}:{node.name}", node.end_lineno - node.lineno + 1))
    return found


FUNCTIONS = _functions()


@pytest.mark.parametrize(
    "name, lines",
    FUNCTIONS,
    ids=[name for name, _ in FUNCTIONS],
)
def test_no_cli_function_is_over_60_lines(name: str, lines: int) -> None:
    assert lines <= MAX_LINES, f"{name} is {lines} lines: move what it computes into the library"


def test_error_messages_name_the_flag_of_a_parameter() -> None:
    """The library names ```calibration_group```; the command line says
    ``--calibration-group``, and leaves an unquoted or unknown name alone."""
    assert PARAMETER_FLAGS["calibration_group"] == "--calibration-group"
    message = "`calibration_group` 'x': no such column; calibration_group, `colour`"
    assert name_flags(message) == (
        "--calibration-group 'x': no such column; calibration_group, `colour`"
    )


def test_a_library_error_names_the_parameter_and_the_command_line_its_flag(tmp_path, capsys):
    """``add_trial(topics=...)`` without a bag names ``topics`` and ``bag``; ``dataset add
    --topic`` without ``--bag`` says ``--topic goes with --bag``."""
    from liquidtouch.cli import main
    from liquidtouch.errors import DatasetError
    from liquidtouch.io.dataset_dir import init_dataset
    from liquidtouch.io.recordings import add_trial

    root = init_dataset(tmp_path / "d")
    video = tmp_path / "left.mp4"
    video.write_bytes(b"")
    with pytest.raises(DatasetError, match=r"^`topics` goes with `bag`$"):
        add_trial(root, [video], topics=["/x"])
    assert main(["dataset", "add", str(root), str(video), "--topic", "/x"]) == 2
    assert capsys.readouterr().err.strip() == "error: --topic goes with --bag"
