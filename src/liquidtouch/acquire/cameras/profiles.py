"""Sensor profiles: each sensor's camera mode and how a frame becomes the sensor's image.

Part of :mod:`liquidtouch.acquire.cameras` (see its docstring for the profiles).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from liquidtouch.errors import DeviceError
from liquidtouch.io.image_size import MAX_FRAME_PIXELS


@dataclass(frozen=True)
class CameraProfile:
    """How a sensor's camera is set up and how its frames become the sensor's image.

    ``width`` × ``height`` [px] is the output image size (``None``: unchanged), ``fps``
    [Hz] the nominal frame rate (``None``: the camera's own), ``capture`` the camera
    mode requested from a V4L2 device (width, height, fourcc; ``None``: the
    default), and ``crop_fraction`` the fraction of each border cut off before
    resizing (GelSight Mini: 1/7). A frame that already has the output size is left
    as it is (e.g. a replayed recording of that sensor).
    """

    name: str
    width: int | None
    height: int | None
    fps: float | None
    capture: tuple[int, int, str] | None = None
    crop_fraction: float = 0.0
    description: str = ""

    @property
    def max_pixels(self) -> int:
        """Largest camera frame [pixels] this sensor takes before decoding it: twice each
        side of the mode it asks for (or of its output), so a camera in a larger mode is
        still resized; at most :data:`~liquidtouch.io.image_size.MAX_FRAME_PIXELS`."""
        sizes = []
        if self.capture:
            sizes.append(self.capture[0] * self.capture[1])
        if self.width and self.height:
            sizes.append(self.width * self.height)
        return min(MAX_FRAME_PIXELS, 4 * max(sizes)) if sizes else MAX_FRAME_PIXELS

    def apply(self, frame: np.ndarray) -> np.ndarray:
        """The sensor image of one camera frame (crop the borders, resize; area averaging)."""
        if self.width is None or self.height is None:
            return frame
        h, w = frame.shape[:2]
        if (w, h) == (self.width, self.height):
            return frame
        import cv2  # why: OpenCV is heavy; only a resized profile needs it

        if self.crop_fraction:
            dy, dx = int(h * self.crop_fraction), int(w * self.crop_fraction)
            frame = frame[dy : h - dy, dx : w - dx]
        return cv2.resize(frame, (self.width, self.height), interpolation=cv2.INTER_AREA)


PROFILES: dict[str, CameraProfile] = {
    "raw": CameraProfile("raw", None, None, None, description="frames as the camera gives them"),
    "mini": CameraProfile(
        "mini",
        320,
        240,
        25.0,
        capture=(3280, 2464, "MJPG"),
        crop_fraction=1 / 7,
        description="GelSight Mini: MJPG 3280x2464 at <=25 fps, 1/7 border cropped, 320x240",
    ),
    "r15": CameraProfile(
        "r15", 640, 480, 30.0, description="GelSight R1.5 (mjpg-streamer): 640x480 at 30 fps"
    ),
    "digit": CameraProfile(
        "digit", 320, 240, 60.0, capture=(320, 240, "MJPG"), description="DIGIT: 320x240, 60 fps"
    ),
}


def get_profile(profile: str | CameraProfile) -> CameraProfile:
    """A profile by name (:data:`PROFILES`); :class:`DeviceError` for an unknown one."""
    if isinstance(profile, CameraProfile):
        return profile
    try:
        return PROFILES[str(profile)]
    except KeyError:
        raise DeviceError(
            f"unknown sensor profile {profile!r}; choose one of {', '.join(PROFILES)}"
        ) from None
