"""Synthetic camera frames that carry their own frame number, for streaming and recording tests.

:class:`CodedFrames` is a ``frame_source`` for
:class:`liquidtouch.sim.rig.mjpeg.MjpegServer`: frame k shows k in binary as a row
of black/white squares along the top (robust to JPEG and grey conversion) and a
dark dot at a position that is a known function of k, so a test can tell which
server frame every received or recorded frame is, and check its content.
"""

from __future__ import annotations

import threading

import numpy as np

BITS = 12
SQUARE_PX = 20


class CodedFrames:
    """Callable frame source: frame k (k = 0, 1, ...) encodes k; BGR uint8 (h, w, 3)."""

    def __init__(self, width: int = 320, height: int = 240) -> None:
        if width < BITS * SQUARE_PX or height < 3 * SQUARE_PX:
            raise ValueError("frame too small for the code")
        self.width, self.height = width, height
        self.calls = 0
        self._lock = threading.Lock()

    def dot_center(self, k: int) -> tuple[float, float]:
        """Where frame k's dot is (x, y) [px]."""
        x = self.width / 2 + 0.3 * self.width * np.sin(2 * np.pi * k / 45)
        y = self.height / 2 + SQUARE_PX
        return float(x), float(y)

    def __call__(self) -> np.ndarray:
        import cv2

        with self._lock:
            k = self.calls
            self.calls += 1
        image = np.full((self.height, self.width, 3), 160, np.uint8)
        for bit in range(BITS):
            value = 255 if (k >> bit) & 1 else 0
            image[:SQUARE_PX, bit * SQUARE_PX : (bit + 1) * SQUARE_PX] = value
        x, y = self.dot_center(k)
        cv2.circle(image, (round(x), round(y)), 8, (20, 20, 20), -1, lineType=cv2.LINE_AA)
        return image


def frame_number(image: np.ndarray) -> int:
    """The frame number a :class:`CodedFrames` image encodes (grey or BGR)."""
    grey = image if image.ndim == 2 else image.mean(axis=2)
    row = grey[SQUARE_PX // 2]
    centres = (np.arange(BITS) * SQUARE_PX + SQUARE_PX // 2).astype(int)
    return int(sum(1 << bit for bit, c in enumerate(centres) if row[c] > 128))


def dot_position(image: np.ndarray) -> tuple[float, float]:
    """Centroid (x, y) [px] of the dark dot below the code row."""
    grey = (image if image.ndim == 2 else image.mean(axis=2)).astype(float)
    grey[: 2 * SQUARE_PX] = 255.0
    weight = np.clip(100.0 - grey, 0, None)
    ys, xs = np.indices(grey.shape)
    total = weight.sum()
    return float((xs * weight).sum() / total), float((ys * weight).sum() / total)
