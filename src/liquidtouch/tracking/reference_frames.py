"""Marker tracks from a lossy video's reference frames only (I and P), B-frames re-interpolated.

Why: in H.264 with B-frames (x264's default from the ``veryfast`` preset on,
``bframes=3``) the B-frames are quantised more coarsely than the frames they
are predicted from and are never themselves a reference, so the encoder spends
few bits on them: a marker that moves a few hundredths of a pixel per frame
stays where the prediction put it. On simulated GelSight trials (x264 ``fast``,
CRF 18) the tracked/true motion gain of B-frames fell from 0.94 at 0.8 px to
0.69 at 0.18 px while the P-frames kept 0.97–0.99 at every amplitude
(``benchmarks/codec_bias.py``, ``--mechanism``): the falling gain is what makes
λ come out too high. The reference frames are one in ~4 of a 30 fps video,
still > 2 samples per period of a 2–3 Hz slosh, so the B-frame positions are
replaced by a cubic spline through the reference frames' positions.

:func:`frame_types` reads the picture type of every decoded frame;
:func:`reference_frame_tracks` rebuilds the tracks.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from liquidtouch.tracking.tracks import MarkerTracks

#: fewest reference frames a marker needs for the spline (else its B-frames are kept)
MIN_REFERENCE_FRAMES = 8


def frame_types(path: str | Path) -> np.ndarray:
    """Picture type of every decoded frame of a video: ``"I"``, ``"P"``, ``"B"`` (else ``"?"``).

    Decodes the whole file (decoding is ~10× faster than tracking); the order is
    the decoder's output order, as :func:`liquidtouch.io.frames.iter_video` yields it.
    """
    import av

    names = {1: "I", 2: "P", 3: "B"}
    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        stream.thread_type = "AUTO"
        return np.array([names.get(int(f.pict_type), "?") for f in container.decode(stream)])


def reference_frame_tracks(tracks: MarkerTracks, types: np.ndarray) -> MarkerTracks:
    """``tracks`` with every B-frame position replaced by a cubic spline through the I/P frames.

    ``types`` [frames] are :func:`frame_types` of the video ``tracks`` came from
    (same length). A marker's B-frame positions are only re-interpolated
    between its first and last valid reference frames, and only when it has
    :data:`MIN_REFERENCE_FRAMES` of them; validity is unchanged.
    """
    from scipy.interpolate import CubicSpline

    types = np.asarray(types)
    if len(types) != len(tracks.t):
        raise ValueError(f"{len(types)} frame types for {len(tracks.t)} tracked frames")
    is_b = types == "B"
    positions = tracks.positions.copy()
    for m in range(tracks.n_markers):
        ref = np.flatnonzero(~is_b & tracks.valid[:, m])
        if len(ref) < MIN_REFERENCE_FRAMES:
            continue
        inside = np.zeros(len(types), bool)
        inside[ref[0] : ref[-1] + 1] = True
        target = is_b & inside & tracks.valid[:, m]
        if target.any():
            spline = CubicSpline(tracks.t[ref], tracks.positions[ref, m], axis=0)
            positions[target, m] = spline(tracks.t[target])
    return replace(tracks, positions=positions)
