"""Shared test helpers: synthetic GelSight marker images with known marker positions,
Chromium for the browser checks, fewer random draws for the experiments, a
directory built once per test run however many xdist workers need it, and a
regression stand-in that records what the live estimator gives it.

Test modules import these (``from helpers import grid, render_blobs``; ``tests/`` is on
pytest's ``pythonpath``) instead of importing each other. The synthetic feature
tables live in ``liquidtouch.testing.synthetic_tables`` (shared with the benchmarks).
"""

from __future__ import annotations

import fcntl
import os
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from scipy.special import erf

from liquidtouch.experiments import data_efficiency, reproduce, transfer

#: the repository's root
REPO = Path(__file__).resolve().parents[1]
#: the workplace's shared files (real recordings, the independent validation set): tests
#: that read them skip when they are absent
SHARED = REPO.parent / "shared"


def render_blobs(positions: np.ndarray, shape=(160, 200), radius=4.5, gain=1.0, noise=0.0, seed=0):
    """Soft dark discs (anti-aliased edge) on a lit gradient background, uint8."""
    height, width = shape
    yy, xx = np.mgrid[0:height, 0:width].astype(float)
    light = gain * (150 + 60 * xx / width + 20 * np.sin(yy / 40))
    ink = np.zeros(shape)
    # beyond radius + 6 px, erf((r - radius) / 0.9) is exactly 1.0 in float64 and the ink
    # exactly 0: each disc is drawn in its window only (the same image, 25 -> 1.5 ms a frame)
    reach = radius + 6.0
    for x, y in positions:
        if np.isfinite(x) and np.isfinite(y):
            cols = slice(max(int(np.floor(x - reach)), 0), max(int(np.ceil(x + reach)) + 1, 0))
            rows = slice(max(int(np.floor(y - reach)), 0), max(int(np.ceil(y + reach)) + 1, 0))
        else:
            cols = rows = slice(None)
        r = np.hypot(xx[rows, cols] - x, yy[rows, cols] - y)
        ink[rows, cols] = np.maximum(ink[rows, cols], 0.5 * (1 - erf((r - radius) / 0.9)))
    image = light * (1 - 0.75 * ink)
    if noise:
        image = image + np.random.default_rng(seed).normal(0, noise, shape)
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def grid(shape=(160, 200), pitch=24.0, jitter=0.3, seed=0):
    """Marker centres (x, y) [px] on a square grid of ``pitch`` px, jittered by ±``jitter``."""
    rng = np.random.default_rng(seed)
    ys, xs = np.mgrid[20 : shape[0] - 15 : pitch, 20 : shape[1] - 15 : pitch]
    pts = np.stack([xs.ravel(), ys.ravel()], axis=1).astype(float)
    return pts + rng.uniform(-jitter, jitter, pts.shape)


def chromium_or_skip() -> str:
    """Path of headless Chromium; without it skip locally, but FAIL when ``CI`` is set.

    CI must not skip the browser checks silently (``.ci/run`` installs Debian's
    ``chromium``).
    """
    import pytest

    from liquidtouch.testing.chromium import find_chromium

    path = find_chromium()
    if path is None:
        if os.environ.get("CI"):
            pytest.fail("CI is set but chromium is not installed (.ci/run installs it)")
        pytest.skip("chromium is not installed (apt-get install chromium) and CI is not set")
    return path


def fewer_experiment_draws(patch: pytest.MonkeyPatch) -> None:
    """Experiments 6 and 7 with fewer random draws (their curves' sizes and repeats).

    The data-efficiency and transfer curves average many GPR fits over random
    subsets (~40 CPU-s of a run on the synthetic tables); a test whose claim is
    not about those averages (the report's layout, an experiment that cannot
    run, the pipeline end to end) runs them on fewer draws, set through ``patch``:
    seconds, not a minute.
    """
    patch.setattr(data_efficiency, "SIZES", (6, 10, 20))
    patch.setattr(data_efficiency, "REPEATS", 1)
    patch.setattr(transfer, "SIZES", (5, 15))
    patch.setattr(transfer, "REPEATS", 2)
    patch.setattr(reproduce, "STREAMED_TRIALS_QUICK", 1)  # experiment 9: one replayed trial


def built_once(
    tmp_path_factory: pytest.TempPathFactory, name: str, build: Callable[[Path], None]
) -> Path:
    """Directory ``name``, filled by ``build(directory)`` once per test run, shared by workers.

    ``--dist worksteal`` may split a module between the workers, and each would then
    set up the module's fixtures again (the synthetic report: ~55 CPU-s). Here the first
    worker to need the directory builds it under an exclusive lock in the run's temporary
    root (common to the workers); the other waits on the lock, then reads the finished
    directory. A build that raises leaves no ``.complete`` mark, so a later caller tries
    again (and fails the same way). Tests must only read the directory.
    """
    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent  # the run's root, above popen-gw0, popen-gw1
    directory = root / name
    with open(root / f"{name}.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        if not (directory / ".complete").is_file():
            shutil.rmtree(directory, ignore_errors=True)  # a failed build's leftovers
            directory.mkdir()
            build(directory)
            (directory / ".complete").touch()
    return directory


class RecordingModel:
    """A regression model stand-in for ``live_updates``: records the features and their std
    each refresh gives it (``calls[i]`` = (X row, X_std row)) and predicts ``i`` for target
    ``call``, so an update says which call it came from."""

    kind = "regression"
    targets = ("call",)

    def __init__(self) -> None:
        self.calls: list[tuple[np.ndarray, np.ndarray]] = []

    def predict(self, X, X_std=None):
        self.calls.append((np.asarray(X, float)[0], np.asarray(X_std, float)[0]))
        return {"call": (np.array([len(self.calls) - 1.0]), np.array([0.0]))}

    def in_domain(self, X) -> np.ndarray:
        return np.ones(len(X), bool)


def jpeg_claiming(width: int, height: int) -> bytes:
    """A small valid JPEG whose frame header (SOF0) claims ``width`` x ``height`` px: a few
    hundred bytes that would decode to gigabytes (issue 41)."""
    import cv2

    ok, data = cv2.imencode(".jpg", np.zeros((8, 8), np.uint8))
    assert ok
    raw = bytearray(data.tobytes())
    sof = raw.index(b"\xff\xc0")
    raw[sof + 5 : sof + 9] = height.to_bytes(2, "big") + width.to_bytes(2, "big")
    return bytes(raw)
