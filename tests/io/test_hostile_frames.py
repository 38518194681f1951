"""Frames that would cost gigabytes, and sensors that extract would refuse (issue 41, item 5).

A 689-byte JPEG claiming 20000 x 20000 px cost 6.8 GB in ``extract``; 65000 x 65000 in a
bag gave ``cv2.error``. The size an image declares is checked before it is decoded, in
image folders, bags and videos. ``dataset add`` refuses what ``extract`` would refuse,
with the same check (a 1-frame video, a bag topic over 36 000 frames).
"""

from __future__ import annotations

import io
import time
from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np
import pytest
from helpers import grid, jpeg_claiming, render_blobs

from liquidtouch.cli import main
from liquidtouch.errors import DatasetError, VideoError
from liquidtouch.io import rosbag
from liquidtouch.io.frames import iter_image_folder, iter_video
from liquidtouch.io.image_size import MAX_FRAME_PIXELS, check_image_bytes, declared_size
from liquidtouch.tracking import tracks

EPOCH_NS = 1_700_000_000_000_000_000


def _run(capsys, *argv):
    status = main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert status == 2 and err.startswith("error: ") and err.count("\n") == 1, err
    return err


@pytest.mark.parametrize("suffix", [".png", ".jpg", ".bmp", ".tif"])
def test_the_declared_size_is_read_from_every_image_format_a_folder_holds(suffix):
    ok, data = cv2.imencode(suffix, np.zeros((37, 53, 3), np.uint8))
    assert ok and declared_size(io.BytesIO(data.tobytes())) == (53, 37)


def test_a_jpeg_claiming_gigapixels_is_refused_before_decoding(tmp_path, capsys):
    data = jpeg_claiming(20000, 20000)
    assert len(data) < 1000 and declared_size(io.BytesIO(data)) == (20000, 20000)
    with pytest.raises(VideoError, match="declares 20000x20000 px"):
        check_image_bytes(data, "a frame", VideoError)
    folder = tmp_path / "left"
    folder.mkdir()
    (folder / "0.jpg").write_bytes(data)
    for k in range(1, 4):
        cv2.imwrite(str(folder / f"{k}.jpg"), np.full((40, 50), 128, np.uint8))
    start = time.monotonic()
    with pytest.raises(VideoError, match="declares 20000x20000 px"):
        list(iter_image_folder(folder, fps=30.0))
    assert "declares 20000x20000" in _run(capsys, "extract", folder, "--fps", "30")
    assert time.monotonic() - start < 10  # nothing decoded (before: 6.8 GB)
    assert main(["dataset", "init", str(tmp_path / "ds")]) == 0
    err = _run(capsys, "dataset", "add", tmp_path / "ds", folder, "--fps", "30")
    assert "declares 20000x20000" in err and not (tmp_path / "ds" / "trial-0001").exists()
    (folder / "0.jpg").write_bytes(jpeg_claiming(1, 16_000))  # thin, few pixels: no sensor
    with pytest.raises(VideoError, match="1 to 8192 px on a side"):
        list(iter_image_folder(folder, fps=30.0))
    assert 20000 * 20000 > MAX_FRAME_PIXELS


def _write_video(path: Path, n_frames: int, size=(200, 160)) -> Path:
    """An FFV1 video of markers at rest (``size``: width, height)."""
    image = render_blobs(grid(), shape=size[::-1]) if size == (200, 160) else None
    with av.open(str(path), "w") as out:
        stream = out.add_stream("ffv1", rate=Fraction(30))
        stream.width, stream.height, stream.pix_fmt = *size, "gray"
        for _ in range(n_frames):
            grey = image if image is not None else np.zeros(size[::-1], np.uint8)
            frame = av.VideoFrame.from_ndarray(grey, format="gray")
            out.mux(stream.encode(frame))
        out.mux(stream.encode())
    return path


def test_a_video_of_one_frame_is_refused_by_dataset_add_as_extract_refuses_it(tmp_path, capsys):
    video = _write_video(tmp_path / "left.mkv", 1)
    assert main(["dataset", "init", str(tmp_path / "ds")]) == 0
    err = _run(capsys, "dataset", "add", tmp_path / "ds", video)
    assert "holds 1 frame(s); a sensor's recording needs at least 2" in err
    with pytest.raises(VideoError, match=r"holds 1 frame\(s\)"):
        tracks.track_markers(iter_video(video), "left")


def test_a_video_stream_declaring_a_frame_no_sensor_has_is_refused(tmp_path):
    video = _write_video(tmp_path / "wide.mkv", 3, size=(8200, 2))
    with pytest.raises(VideoError, match="declares 8200x2 px"):
        list(iter_video(video))


# -- bags --------------------------------------------------------------------------------------


def _bag(path: Path, bodies: list[bytes]) -> Path:
    """A ROS 2 bag of one CompressedImage topic holding ``bodies`` (JPEG bytes)."""
    pytest.importorskip("rosbags")
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    types = store.types
    msgtype = "sensor_msgs/msg/CompressedImage"
    with Writer(path, version=9) as writer:
        connection = writer.add_connection("/left/image/compressed", msgtype, typestore=store)
        for k, body in enumerate(bodies):
            ns = EPOCH_NS + k * 33_333_333
            stamp = types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
            header = types["std_msgs/msg/Header"](stamp=stamp, frame_id="gelsight")
            data = np.frombuffer(body, np.uint8)
            msg = types[msgtype](header=header, format="jpeg", data=data)
            writer.write(connection, ns, store.serialize_cdr(msg, msgtype))
    return path


def _jpeg(k: int) -> bytes:
    ok, data = cv2.imencode(".jpg", np.full((40, 50), 10 * k, np.uint8))
    assert ok
    return data.tobytes()


def test_a_bag_image_claiming_65000_px_a_side_is_refused(tmp_path, capsys):
    bag = _bag(tmp_path / "bag", [_jpeg(0), _jpeg(1), jpeg_claiming(65000, 65000)])
    assert main(["dataset", "init", str(tmp_path / "ds")]) == 0
    err = _run(capsys, "dataset", "add", tmp_path / "ds", "--bag", bag)  # before: cv2.error
    assert "message 2 declares 65000x65000 px" in err


def test_a_bag_topic_over_the_frames_extract_tracks_is_refused(tmp_path, monkeypatch):
    """``dataset add --bag`` skipped the 36 000-frames-per-sensor limit (here 5, to be fast)."""
    monkeypatch.setattr(tracks, "MAX_FRAMES", 5)
    monkeypatch.setattr(rosbag, "MAX_FRAMES", 5)
    bag = _bag(tmp_path / "bag", [_jpeg(k) for k in range(7)])
    with pytest.raises(DatasetError, match="holds 6 frames, more than the 5 tracked"):
        rosbag.import_bag(bag, tmp_path / "out")
