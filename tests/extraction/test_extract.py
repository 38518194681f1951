"""End to end from video files through the CLI: synthetic videos written with PyAV, error paths."""

from __future__ import annotations

import json

import av
import numpy as np
import pytest
from helpers import grid, render_blobs

from liquidtouch.cli import main
from liquidtouch.errors import SignalError, VideoError
from liquidtouch.io.frames import iter_video

LAM, OMEGA = 0.7, 2 * np.pi * 1.2


def write_video(path, n_frames=150, fps=30, amplitude=2.0):
    rest = grid()
    with av.open(str(path), "w") as out:
        stream = out.add_stream("libx264", rate=fps, options={"crf": "10"})
        stream.width, stream.height, stream.pix_fmt = 200, 160, "yuv420p"
        for k in range(n_frames):
            t = k / fps
            shift = amplitude * np.exp(-LAM * t) * np.cos(OMEGA * t)
            grey = render_blobs(rest + np.array([shift, 0.3 * shift]))
            frame = av.VideoFrame.from_ndarray(np.dstack([grey] * 3), format="rgb24")
            out.mux(stream.encode(frame))
        out.mux(stream.encode())
    return path


def test_extract_cli_json_and_outputs(tmp_path, capsys):
    video = write_video(tmp_path / "left.mp4")
    times = [t for t, _ in iter_video(video)]
    assert np.allclose(np.diff(times), 1 / 30)
    rc = main(["extract", str(video), "--json", "--signal-out", str(tmp_path / "u.csv")])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out["n_markers"] == 16 and out["frames"] == 150 and out["fps"] == pytest.approx(30)
    assert out["explained_variance"] > 0.95
    assert out["angular_frequency"] == pytest.approx(OMEGA, rel=0.02)
    assert (tmp_path / "u.csv").read_text().startswith("t,u")


def test_extract_errors(tmp_path, capsys):
    empty = tmp_path / "empty.mp4"
    empty.write_bytes(b"")
    text = tmp_path / "notes.mp4"
    text.write_text("not a video")
    for bad in (tmp_path / "missing.mp4", empty, text):
        assert main(["extract", str(bad)]) == 2
        err = capsys.readouterr().err
        assert err.startswith("error: ") and err.count("\n") == 1
    a = write_video(tmp_path / "a.mp4", n_frames=90)
    b = write_video(tmp_path / "b.mp4", n_frames=60)
    assert main(["extract", str(a), str(b)]) == 2
    assert "differ in length" in capsys.readouterr().err
    with pytest.raises(VideoError, match="is not a file"):
        list(iter_video(tmp_path))  # a folder is not a video file


def test_extract_checks_signal_options_before_reading_any_video(tmp_path):
    from liquidtouch.errors import SignalError
    from liquidtouch.extraction.pipeline import extract

    missing = tmp_path / "missing.mp4"  # would be a VideoError if it were read
    with pytest.raises(SignalError, match="n_markers must be a whole number >= 1"):
        extract(missing, n_markers=0)
    with pytest.raises(SignalError, match="lowpass_hz must be a cut-off frequency"):
        extract(missing, lowpass_hz=-1.0)


def test_extract_sensor_choice_and_fit_options(tmp_path, capsys):
    from liquidtouch.extraction.fit_settings import FitSettings
    from liquidtouch.extraction.pipeline import extract

    a = write_video(tmp_path / "a.mp4")
    b = write_video(tmp_path / "b.mp4", amplitude=1.0)
    assert main(["extract", str(a), str(b), "--sensor", "c"]) == 2
    assert "no sensor 'c'; the sensors are a, b" in capsys.readouterr().err
    assert main(["extract", str(a), str(b), "--sensor", "b", "--json", "--start", "0"]) == 0
    only_b = json.loads(capsys.readouterr().out)
    assert only_b["t0"] == 0.0 and only_b["angular_frequency"] == pytest.approx(OMEGA, rel=0.02)
    direct = extract([a, b], sensors=["b"], fit_settings=FitSettings(start=0.0, loss="ls"))
    assert [tr.sensor for tr in direct.tracks] == ["b"] and direct.fit.loss == "ls"
    with pytest.raises(SignalError, match="unknown loss 'l1'"):
        FitSettings(loss="l1")
    with pytest.raises(SignalError, match="0 < low < high"):
        FitSettings(band_hz=(5.0, 1.0))
    with pytest.raises(SignalError, match="'auto' or a time in seconds"):
        FitSettings(start="soon")
