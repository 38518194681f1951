"""Rendering the rig's two GelSight sensors live, one frame at a time, as the loads move them.

Part of the simulated rig (:mod:`liquidtouch.sim.rig.rig`).
"""

from __future__ import annotations

import threading
from typing import Any

import numpy as np
from numpy.lib.stride_tricks import as_strided

from liquidtouch.sim.gelsight import gel_displacement
from liquidtouch.sim.loads import FingerLoads
from liquidtouch.sim.render import iter_frames, make_background

FRAME_BLOCK = 108_000
"""Frames rendered per renderer set-up (an hour at 30 fps), then it is set up again."""


class LiveSensor:
    """Renders one GelSight sensor's current frame on demand.

    Uses :func:`~liquidtouch.sim.render.iter_frames` with stride-0 position and
    offset arrays: every frame reads the single (N, 2) buffer this class writes just
    before asking for the frame (the generator reads row ``i`` of its inputs only when
    drawing frame ``i``), so the renderer's set-up (background padding, marker
    look-up table, noise tile) is done once per :data:`FRAME_BLOCK` frames.
    """

    def __init__(self, index: int, profile, rest_px: np.ndarray, seed: int, geometry):
        self.index, self.profile, self.rest = index, profile, rest_px
        self.seed, self.geometry = seed, geometry
        self.background = make_background(profile, np.random.default_rng([seed, index + 1]))
        self._lock = threading.Lock()
        self._positions = rest_px.astype(np.float64).copy()
        self._offset = np.zeros(2)
        self._field = np.zeros(3)  # a plain gel's shear at the centre (x, y) [px], twist [rad]
        self._frames: dict[bool, tuple[Any, int]] = {}

    def _generator(self, contact: bool):
        positions = as_strided(
            self._positions,
            shape=(FRAME_BLOCK, *self._positions.shape),
            strides=(0, *self._positions.strides),
        )
        offsets = as_strided(self._offset, shape=(FRAME_BLOCK, 2), strides=(0, 8))
        # the same seed for both generators: identical marker sizes and ink
        rng = np.random.default_rng([self.seed, self.index + 1, 7])
        kwargs: dict[str, Any] = {"background": self.background}
        if contact:
            kwargs.update(
                contact_center_px=self.geometry.center_px[self.index],
                contact_radius_px=float(self.geometry.radius_px[self.index]),
                contact_offsets_px=offsets,
            )
        if self.profile.gel == "plain":  # no markers; the imprint moves with the gel's field
            positions = positions[:, :0]
            if contact:
                kwargs["imprint_motion"] = self._motion
        return iter_frames(positions, self.profile, rng, **kwargs)

    def _motion(self, frame: int, rel_px: np.ndarray) -> np.ndarray:
        """The plain gel's displacement at ``rel_px`` (N, 2) now (the field set by render)."""
        sigma = float(self.geometry.field_sigma_px[self.index])
        shear, angle = self._field[None, :2], self._field[2:]
        return gel_displacement(rel_px, sigma, shear, angle)[0]

    def prepare(self) -> None:
        """Set up both renderers now (about a second) rather than at the first frame."""
        with self._lock:
            for contact in (False, True):
                if contact not in self._frames:
                    self._frames[contact] = (self._generator(contact), 0)

    def render(
        self,
        positions: np.ndarray,
        offset: np.ndarray,
        contact: bool,
        field: np.ndarray | None = None,
    ) -> np.ndarray:
        """The BGR frame (H, W, 3) with markers at ``positions`` and the imprint if ``contact``;
        on a plain gel ``field`` (shear x, y [px], twist [rad]) moves the imprint."""
        import cv2  # why: OpenCV is heavy; imported when the first frame is rendered

        with self._lock:
            generator, used = self._frames.get(contact, (None, FRAME_BLOCK))
            if generator is None or used >= FRAME_BLOCK:
                generator, used = self._generator(contact), 0
            self._positions[:] = positions
            self._offset[:] = offset
            self._field[:] = 0.0 if field is None else field
            frame = cv2.cvtColor(next(generator), cv2.COLOR_RGB2BGR)  # a new array
            self._frames[contact] = (generator, used + 1)
        return frame


def loads_near(loads: FingerLoads, t_s: float, margin_s: float = 0.25) -> FingerLoads:
    """The samples of ``loads`` within ``margin_s`` of ``t_s``: a frame's exposure needs no
    more, and the per-frame work no longer grows with the trial's length."""
    t = loads.t_s
    lo = max(int(np.searchsorted(t, t_s - margin_s)) - 1, 0)
    hi = min(int(np.searchsorted(t, t_s + margin_s)) + 1, len(t))
    hi = max(hi, lo + 2)
    return FingerLoads(
        t_s=t[lo:hi],
        shear_force_n=loads.shear_force_n[lo:hi],
        twist_moment_nmm=loads.twist_moment_nmm[lo:hi],
        normal_force_n=loads.normal_force_n,
        contact_center_mm=loads.contact_center_mm,
    )
