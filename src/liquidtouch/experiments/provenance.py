"""What produced a report: versions, git commit, date, seeds, sensor profile, machine."""

from __future__ import annotations

import datetime
import os
import platform
import subprocess
import sys
from importlib import metadata
from pathlib import Path

from liquidtouch import __version__

#: (label, distribution names to try) of the libraries the results depend on.
LIBRARIES = (
    ("numpy", ("numpy",)),
    ("scipy", ("scipy",)),
    ("scikit-learn", ("scikit-learn",)),
    ("OpenCV", ("opencv-python-headless", "opencv-python", "opencv-contrib-python")),
    ("PyAV", ("av",)),
    ("pandas", ("pandas",)),
    ("matplotlib", ("matplotlib",)),
)


def _version(distributions: tuple[str, ...]) -> str:
    for name in distributions:
        try:
            return metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return "not installed"


def _git(*args: str, cwd: Path) -> tuple[bool, str]:
    """``git args`` in ``cwd``: (ok, first line of stdout or the reason it failed)."""
    try:
        done = subprocess.run(
            ["git", *args],
            cwd=cwd,
            capture_output=True,
            text=True,
            timeout=10,
            check=False,
            env={**os.environ, "GIT_TERMINAL_PROMPT": "0", "GIT_OPTIONAL_LOCKS": "0"},
        )
    except FileNotFoundError:
        return False, "git is not installed"
    except (OSError, subprocess.SubprocessError) as exc:
        return False, f"git failed: {type(exc).__name__}"
    if done.returncode != 0:
        reason = (done.stderr.strip().splitlines() or ["unknown error"])[0]
        return False, reason[:120]
    return True, done.stdout.strip()


def git_commit(where: str | Path | None = None) -> str:
    """The commit of the checkout holding ``where`` (default: this package's source).

    ``"none (not a git checkout: …)"`` when there is no commit to report (an
    installed wheel, no git); ``"… (with uncommitted changes)"`` when the
    tracked files differ from it.
    """
    cwd = Path(where) if where is not None else Path(__file__).resolve().parent
    ok, out = _git("rev-parse", "HEAD", cwd=cwd)
    if not ok:
        return f"none ({out})"
    ok_status, status = _git("status", "--porcelain", "--untracked-files=no", cwd=cwd)
    if ok_status and status:
        return f"{out} (with uncommitted changes)"
    return out


def machine() -> str:
    """``"Linux-6.1 x86_64, 8 cores (2 usable by this process)"``."""
    cores = os.cpu_count() or 0
    try:
        usable = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        usable = cores
    text = f"{platform.platform(terse=True)} {platform.machine()}, {cores} cores"
    return text + (f" ({usable} usable by this process)" if usable != cores else "")


def provenance(**extra: object) -> dict[str, str]:
    """Ordered provenance items; ``extra`` (seeds, sensor, workers...) goes after the date."""

    items = {
        "liquidtouch": __version__,
        "git commit": git_commit(),
        "date": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M:%S UTC"),
    }
    items.update({key: str(value) for key, value in extra.items()})
    items["Python"] = f"{platform.python_version()} ({sys.implementation.name})"
    items.update({label: _version(names) for label, names in LIBRARIES})
    items["machine"] = machine()
    return items
