"""The codec diagnostic: frozen marker steps, the codec and x264's settings, extract's warning."""

from __future__ import annotations

import json
import math

import av
import numpy as np
import pytest

from liquidtouch.cli import main
from liquidtouch.extraction.codec_check import (
    X264_CRF_BIAS,
    check_codec,
    expected_lambda_bias,
    frozen_steps,
    x264_settings,
)
from liquidtouch.extraction.pipeline import extract
from liquidtouch.io.frames import video_info
from liquidtouch.sim.encode import encode_video
from liquidtouch.sim.trial import simulate_trial
from liquidtouch.sim.trial_io import write_trial
from liquidtouch.tracking.tracks import MarkerTracks


def moving_tracks(n_frames: int = 60, n_markers: int = 4, seed: int = 0) -> MarkerTracks:
    """Markers oscillating by ~1 px with 0.01 px noise (no step is exactly zero)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n_frames) / 30.0
    rest = np.column_stack([np.arange(n_markers) * 20.0 + 10, np.full(n_markers, 30.0)])
    shift = np.sin(2 * np.pi * 2.0 * t)[:, None, None] * np.array([1.0, 0.3])
    pos = rest[None] + shift + rng.normal(0, 0.01, (n_frames, n_markers, 2))
    return MarkerTracks(t, pos, np.ones((n_frames, n_markers), bool), rest.copy(), "s")


def test_frozen_steps_counts_exact_zero_steps_while_others_move():
    tracks = moving_tracks()
    assert frozen_steps([tracks]) == (0.0, pytest.approx(math.nan, nan_ok=True))
    frozen_at = [5, 6, 7, 20, 33]  # marker 0 repeats its position at these frames
    for k in frozen_at:
        tracks.positions[k, 0] = tracks.positions[k - 1, 0]
    tracks.positions[50] = tracks.positions[49]  # a repeated frame: no marker moved
    counted = 4 * (60 - 1) - 4  # the repeated frame's 4 steps are not counted
    share, step_px = frozen_steps([tracks])
    assert share == pytest.approx(len(frozen_at) / counted)
    assert 0.01 < step_px < 2 * np.pi * 2.0 * 1.05 / 30  # the others' per-frame motion


def test_expected_bias_lossless_zero_and_grows_with_crf():
    assert expected_lambda_bias("ffv1") == 0.0 == expected_lambda_bias("png")
    assert expected_lambda_bias("h264", {"rc": "cqp", "qp": "0"}) == 0.0
    biases = [expected_lambda_bias("h264", {"crf": f"{c}.0"}) for c, _ in X264_CRF_BIAS]
    assert biases == [b for _, b in X264_CRF_BIAS] and np.all(np.diff(biases) > 0)
    assert math.isnan(expected_lambda_bias("some-codec"))
    assert check_codec([moving_tracks()]).lossless is None  # imported tracks: codec unknown


def transcode(src, dst, *, crf: int, preset: str = "fast") -> None:
    """Re-encode the frames of ``src`` with x264's defaults (dead zone on) at ``crf``."""
    with av.open(str(src)) as container:
        decoded = [(f.time, f.to_ndarray(format="rgb24")) for f in container.decode(video=0)]
    t_s = np.array([t for t, _ in decoded])
    encode_video(dst, [f for _, f in decoded], t_s, 25.0, crf=crf, preset=preset, x264_params="")


@pytest.fixture(scope="module")
def videos(tmp_path_factory):
    """A moving simulated trial (GelSight Mini, 5 s) lossless (x264 qp=0) and at CRF 28."""
    root = tmp_path_factory.mktemp("codec")
    trial = simulate_trial("water", height_mm=32.0, seed=1, duration_s=5.0)
    lossless = write_trial(trial, root / "lossless", sensor="mini", x264_params="qp=0")
    lossy = root / "crf28"
    lossy.mkdir()
    for name in ("left", "right"):
        transcode(lossless / f"{name}.mp4", lossy / f"{name}.mp4", crf=28)
    return lossless, lossy


@pytest.fixture(scope="module")
def simulator_and_crf23(tmp_path_factory):
    """The simulator's own H.264 (its default settings) and x264's defaults at CRF 23."""
    root = tmp_path_factory.mktemp("codec23")
    trial = simulate_trial("water", height_mm=32.0, seed=1, duration_s=5.0)
    own = write_trial(trial, root / "own", sensor="mini")
    crf23 = root / "crf23"
    crf23.mkdir()
    for name in ("left", "right"):
        transcode(own / f"{name}.mp4", crf23 / f"{name}.mp4", crf=23, preset="medium")
    return own, crf23


def test_no_warning_on_the_simulators_video_one_on_x264_defaults_crf23(simulator_and_crf23):
    own, crf23 = simulator_and_crf23
    mine = extract(own).diagnostics
    assert mine.codec == "h264" and mine.lossless is False  # lossy, but keeps the motion
    assert mine.frozen_step_share <= 0.01
    assert not mine.at_risk and mine.warning() is None and mine.expected_lambda_bias == 0.0
    bad = extract([crf23 / "left.mp4", crf23 / "right.mp4"]).diagnostics
    assert bad.encoder["crf"] == "23.0" and bad.frozen_step_share > 0.01
    assert bad.at_risk and "CRF 23.0" in bad.warning()
    assert bad.expected_lambda_bias == pytest.approx(dict(X264_CRF_BIAS)[23])


def test_codec_and_x264_settings_are_read(videos, tmp_path):
    lossless, lossy = videos
    assert video_info(lossy / "left.mp4").codec == "h264"
    assert x264_settings(lossy / "left.mp4")["crf"] == "28.0"
    assert x264_settings(lossless / "left.mp4")["qp"] == "0"
    ffv1 = tmp_path / "grey.mkv"
    with av.open(str(ffv1), "w") as out:
        stream = out.add_stream("ffv1", rate=25)
        stream.width, stream.height, stream.pix_fmt = 32, 16, "gray"
        for k in range(3):
            image = np.full((16, 32), 10 * k, np.uint8)
            out.mux(stream.encode(av.VideoFrame.from_ndarray(image, format="gray")))
        out.mux(stream.encode())
    assert video_info(ffv1).codec == "ffv1" and x264_settings(ffv1) == {}


def test_diagnostic_near_zero_lossless_high_through_x264_crf28(videos):
    lossless, lossy = videos
    clean = extract(lossless).diagnostics
    assert clean.lossless and not clean.at_risk and clean.warning() is None
    assert clean.frozen_step_share < 0.002  # sensor noise moves every marker every frame
    bad = extract([lossy / "left.mp4", lossy / "right.mp4"]).diagnostics
    assert bad.codec == "h264" and bad.lossless is False and bad.at_risk
    assert bad.frozen_step_share > 0.05  # measured 0.17 here (CRF 18: 0.04)
    assert bad.expected_lambda_bias == pytest.approx(X264_CRF_BIAS[-1][1])
    assert 0 < bad.freezing_step_px < 0.05  # measured 0.007 px/frame: sub-pixel motion freezes


def test_extract_warns_on_lossy_video(videos, capsys):
    lossless, lossy = videos
    assert main(["extract", str(lossy / "left.mp4"), str(lossy / "right.mp4"), "--json"]) == 0
    captured = capsys.readouterr()
    out = json.loads(captured.out)
    assert out["codec"] == "h264" and out["codec_at_risk"] is True and out["codec_crf"] == "28.0"
    assert out["frozen_step_share"] > 0.05 and out["codec_lambda_bias"] > 0.05
    warnings = [line for line in captured.err.splitlines() if line.startswith("warning: ")]
    assert len(warnings) == 1 and "lossy video (h264 CRF 28.0)" in warnings[0]
    assert main(["extract", str(lossless)]) == 0
    captured = capsys.readouterr()
    assert "warning:" not in captured.err
    assert "codec h264 (lossless); frozen marker steps 0.0 %" in captured.out
