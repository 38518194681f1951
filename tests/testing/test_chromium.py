"""Headless Chromium as the browser checks run it (``liquidtouch.testing.chromium``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from liquidtouch.testing.chromium import run_chromium


def test_a_stuck_chromium_is_killed_and_run_again(tmp_path) -> None:
    """A browser that hangs on its first run (with a child that hangs too) is killed,
    children included, and its second run's output is returned; one stuck every time
    gives a clear error, not a hang."""
    script = tmp_path / "browser.sh"
    runs = tmp_path / "runs"
    script.write_text(
        "#!/bin/sh\n"
        f'echo run >> "{runs}"\n'
        f'if [ "$(wc -l < "{runs}")" -eq 1 ] || [ -e "{tmp_path / "always"}" ]; then\n'
        f'  sleep 300 & echo $! > "{tmp_path / "child"}"; wait\n'
        "fi\n"
        'echo "<html>dom</html>"\n'
    )
    script.chmod(0o755)
    done = run_chromium(str(script), "--dump-dom", "about:blank", timeout=2)
    assert done.stdout.strip() == "<html>dom</html>"
    assert runs.read_text().count("run") == 2
    child = int((tmp_path / "child").read_text())
    assert not Path(f"/proc/{child}").exists() or "Z" in Path(f"/proc/{child}/stat").read_text()

    (tmp_path / "always").touch()
    with pytest.raises(RuntimeError, match="stuck 2 times"):
        run_chromium(str(script), "--dump-dom", "about:blank", timeout=1)
