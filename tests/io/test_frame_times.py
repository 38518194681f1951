"""A video's timestamps sidecar (the recorder's <name>.timestamps.csv) wins over Matroska's PTS."""

from __future__ import annotations

import numpy as np
import pytest

from liquidtouch.acquire.cameras import Frame
from liquidtouch.acquire.recording import Ffv1Writer
from liquidtouch.errors import VideoError
from liquidtouch.io.frame_times import video_sidecar
from liquidtouch.io.frames import iter_video


def write_ffv1(directory, times):
    writer = Ffv1Writer(directory, "left", 0.0)
    rng = np.random.default_rng(0)
    for k, t_s in enumerate(times):
        image = rng.integers(0, 255, (48, 64), dtype=np.uint8)  # noise: no two frames alike
        writer.write(Frame("left", k, float(t_s), image), image)
    writer.close()
    return writer.path


def test_the_sidecar_keeps_microseconds_that_matroska_rounds_away(tmp_path):
    # capture times on the monotonic clock; frames 4 and 5 were read back to back after a stall
    times = 5000.0 + np.arange(12) / 30
    times[4] += 0.03
    times[5] = times[4] + 0.0001
    video = write_ffv1(tmp_path, times)
    assert video_sidecar(video).is_file()
    read = np.array([t for t, _ in iter_video(video)])
    np.testing.assert_allclose(read, times - times[0], atol=1e-6)
    # without it, the container's 1 ms PTS give the two frames one time
    video_sidecar(video).unlink()
    pts = np.array([t for t, _ in iter_video(video)])
    assert pts[5] == pts[4]
    np.testing.assert_allclose(pts, times - times[0], atol=1e-3)


def test_a_sidecar_that_does_not_fit_the_video_is_refused(tmp_path):
    video = write_ffv1(tmp_path, np.arange(10) / 30)
    rows = video_sidecar(video).read_text().splitlines()
    video_sidecar(video).write_text("\n".join(rows[:-2]) + "\n")
    with pytest.raises(VideoError, match=r"lists 8 timestamps but the video left\.mkv holds 10"):
        list(iter_video(video))
    video_sidecar(video).write_text("frame,t_s\n" + "".join(f"{k},0.5\n" for k in range(10)))
    with pytest.raises(VideoError, match="must increase strictly"):
        list(iter_video(video))
