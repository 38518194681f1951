"""Headless Chromium (Debian's ``chromium`` package) for the browser checks of the report
and the live page: find it, run it with a timeout, count a screenshot's colours."""

from __future__ import annotations

import logging
import os
import shutil
import signal
import subprocess
import tempfile
from pathlib import Path

from PIL import Image

logger = logging.getLogger(__name__)

BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
#: runs of a stuck Chromium before giving up
ATTEMPTS = 2


def find_chromium() -> str | None:
    """Path of a Chromium-family browser, or None."""
    for name in BROWSERS:
        path = shutil.which(name)
        if path:
            return path
    return None


def run_chromium(browser: str, *args: str, timeout: float) -> subprocess.CompletedProcess:
    """Run headless Chromium with ``args``; a run stuck past ``timeout`` [s] is run again.

    Once in CI a ``--screenshot`` run with ``--virtual-time-budget`` never finished: a
    stuck run is killed with its child processes and started afresh, up to ``ATTEMPTS``.
    """
    for attempt in range(1, ATTEMPTS + 1):
        with tempfile.TemporaryDirectory(prefix="lt-chromium-") as profile:
            command = [
                browser,
                "--headless",
                "--no-sandbox",  # root in a container has no user namespace sandbox
                "--disable-gpu",
                "--disable-dev-shm-usage",
                "--hide-scrollbars",
                "--no-first-run",
                "--allow-file-access-from-files",
                f"--user-data-dir={profile}",
                *args,
            ]
            process = subprocess.Popen(
                command,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
                start_new_session=True,  # its own process group: killed with its children
            )
            try:
                stdout, stderr = process.communicate(timeout=timeout)
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
                process.communicate()
                logger.warning(
                    "chromium: nothing after %.0f s, killed (attempt %d of %d)",
                    timeout,
                    attempt,
                    ATTEMPTS,
                )
                continue
            return subprocess.CompletedProcess(command, process.returncode, stdout, stderr)
    raise RuntimeError(f"chromium was stuck {ATTEMPTS} times for {timeout:.0f} s: {args}")


def screenshot_colours(png: Path) -> int:
    """Number of distinct colours of the screenshot ``png`` (1: blank)."""
    with Image.open(png) as im:
        colours = im.convert("RGB").getcolors(maxcolors=1 << 20)
    return len(colours) if colours is not None else 1 << 20
