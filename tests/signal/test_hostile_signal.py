"""Hostile inputs to the signal chain: frames → tracks → u(t) → free decay → fit.

Each test pins one finding: never a silently wrong number (image folders timed at
a guessed rate, a truncated video, the same video counted twice, a rescaled
signal called flat), never unbounded memory or time (a huge signal or CSV),
never a partial output after a failure, and one clear ``error:`` line (exit 2)
through the command line.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
import time
from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np
import pytest
from helpers import grid, render_blobs

from liquidtouch.cli import main
from liquidtouch.errors import OutputError, SignalError, TableError, VideoError
from liquidtouch.extraction.pipeline import extract, extract_signal
from liquidtouch.fit.oscillation import MAX_SAMPLES, fit_oscillation
from liquidtouch.io.frame_times import TIMESTAMPS_NAME, read_folder_timestamps
from liquidtouch.io.frames import iter_video
from liquidtouch.io.signal_csv import MAX_CSV_BYTES, MAX_CSV_COLUMNS, read_signal_csv
from liquidtouch.io.tables import read_table

MESSAGE_LIMIT = 300  # characters of an error line, at most (plus "error: ")
LAM, OMEGA = 0.7, 2 * np.pi * 1.2


def _run(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str]:
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.err


def _one_error_line(err: str) -> str:
    assert err.startswith("error: ") and err.count("\n") == 1, err[:500]
    return err


def _frames(n_frames: int, fps: float, amplitude: float = 2.0, noise: float = 0.0, seed: int = 0):
    """Grey frames of markers moving as a damped oscillation (amplitude 0: a still sensor)."""
    rest = grid()
    for k in range(n_frames):
        t = k / fps
        shift = amplitude * np.exp(-LAM * t) * np.cos(OMEGA * t)
        yield render_blobs(rest + np.array([shift, 0.3 * shift]), noise=noise, seed=seed + k)


def _write_video(path: Path, frames, fps: float, options: dict[str, str] | None = None) -> Path:
    with av.open(str(path), "w", options=options or {}) as out:
        stream = out.add_stream("libx264", rate=Fraction(fps).limit_denominator(1000))
        stream.options = {"crf": "10"}
        stream.width, stream.height, stream.pix_fmt = 200, 160, "yuv420p"
        for grey in frames:
            frame = av.VideoFrame.from_ndarray(np.dstack([grey] * 3), format="rgb24")
            out.mux(stream.encode(frame))
        out.mux(stream.encode())
    return path


def _write_folder(folder: Path, frames) -> Path:
    folder.mkdir(parents=True)
    for k, grey in enumerate(frames):
        cv2.imwrite(str(folder / f"{k}.png"), grey)
    return folder


# -- 1: image folders are timed by the trial's fps or their timestamps.csv -----------------


@pytest.fixture(scope="module")
def mini_trials(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A simulated GelSight Mini (25 fps) trial as videos and as PNG folders.

    ``video``/``png_timestamps``: the simulator's recording (frame jitter, drops, a
    real rate 1.5 % below nominal), the PNG copy with a timestamps.csv of the PTS.
    ``video_even``/``png_fps``: the same trial rendered on an exact 25 fps clock,
    the PNG copy timed by meta.json's fps alone.
    """
    from liquidtouch.io.dataset import write_trial_meta
    from liquidtouch.sim.gelsight import write_sensor_videos
    from liquidtouch.sim.trial import simulate_trial
    from liquidtouch.sim.trial_io import trial_meta, write_trial
    from liquidtouch.sim.variability import Variability

    root = tmp_path_factory.mktemp("mini")
    trial = simulate_trial("water", height_mm=25.0, seed=1, variability=Variability.none())
    trials = {"video": write_trial(trial, root / "video", sensor="mini")}
    even = root / "video_even"
    recording = write_sensor_videos(trial.loads, even, sensor="mini", seed=1, jitter=False)
    write_trial_meta(even, trial_meta(trial, sensors=list(recording.files), fps=25.0))
    trials["video_even"] = even
    for source, name, stamps in (
        ("video", "png_timestamps", True),
        ("video_even", "png_fps", False),
    ):
        meta = json.loads((trials[source] / "meta.json").read_text())
        assert meta["fps"] == 25.0 and meta["sensors"] == ["left.mp4", "right.mp4"]
        out = root / name
        out.mkdir()
        for sensor in ("left", "right"):
            times, images = zip(*iter_video(trials[source] / f"{sensor}.mp4"), strict=True)
            _write_folder(out / sensor, images)
            if stamps:
                lines = "\n".join(f"{t:.9f}" for t in times)
                (out / sensor / TIMESTAMPS_NAME).write_text(f"t_s\n{lines}\n")
        meta["sensors"] = ["left", "right"]
        (out / "meta.json").write_text(json.dumps(meta))
        trials[name] = out
    return trials


@pytest.mark.slow(seconds=5)
@pytest.mark.parametrize(
    ("videos", "folders"), [("video_even", "png_fps"), ("video", "png_timestamps")]
)
def test_png_folder_trial_gives_the_video_trial_s_decay_rate_and_frequency(
    mini_trials: dict[str, Path], videos: str, folders: str
) -> None:
    # before: folders were timed at 30 fps whatever meta.json said (λ +50 %, ω +23 %)
    reference = extract(mini_trials[videos])
    result = extract(mini_trials[folders])
    assert result.signal.fps == pytest.approx(reference.signal.fps, rel=1e-3)
    assert result.fit.decay_rate == pytest.approx(reference.fit.decay_rate, rel=0.02)
    assert result.fit.angular_frequency == pytest.approx(reference.fit.angular_frequency, rel=0.02)


def test_image_folder_without_fps_or_timestamps_is_refused(tmp_path, capsys) -> None:
    folder = _write_folder(tmp_path / "left", _frames(12, 30.0))
    status, err = _run(capsys, "extract", folder, "--json")
    assert status == 2
    assert "--fps" in _one_error_line(err) and TIMESTAMPS_NAME in err


def test_image_folder_is_timed_by_fps_or_by_its_timestamps(tmp_path) -> None:
    folder = _write_folder(tmp_path / "left", _frames(90, 25.0))
    signal = extract_signal(folder, fps=25.0)
    assert signal.fps == pytest.approx(25.0)
    times = 0.5 + np.arange(90) / 20.0  # any origin; the file wins over fps
    (folder / TIMESTAMPS_NAME).write_text(
        "t_s,frame\n" + "".join(f"{t},{k}\n" for k, t in enumerate(times))
    )
    assert extract_signal(folder, fps=25.0).fps == pytest.approx(20.0)
    assert extract_signal(folder).fps == pytest.approx(20.0)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("t_s\n0\n0.1\n", "lists 2 timestamps but the folder holds 3"),
        ("time\n0\n0.1\n0.2\n", "t_s column"),
        ("t_s\n0\nnan\n0.2\n", "NaN/inf"),
        ("t_s\n0\n0.2\n0.1\n", "increase strictly"),
        ("t_s\n0\n0.1\nsoon\n", "number of seconds"),
    ],
)
def test_bad_timestamps_file_is_refused(tmp_path, text: str, match: str) -> None:
    (tmp_path / TIMESTAMPS_NAME).write_text(text)
    with pytest.raises(VideoError, match=match):
        read_folder_timestamps(tmp_path, 3)


def test_fps_that_contradicts_the_trial_is_refused(tmp_path, capsys) -> None:
    trial = tmp_path / "trial"
    _write_folder(trial / "left", _frames(12, 25.0))
    (trial / "meta.json").write_text(json.dumps({"fps": 25, "sensors": ["left"]}))
    status, err = _run(capsys, "extract", trial, "--fps", "30")
    assert status == 2 and "disagrees" in _one_error_line(err)


def test_feature_cache_notices_fps_timestamps_and_image_changes(tmp_path) -> None:
    from liquidtouch.batch.features import _fingerprint

    trial = tmp_path / "trial"
    folder = _write_folder(trial / "left", _frames(5, 25.0))
    meta = trial / "meta.json"
    meta.write_text(json.dumps({"fps": 25, "sensors": ["left"]}))
    seen = {_fingerprint(trial, "gelsight")}

    stat = meta.stat()
    meta.write_text(json.dumps({"fps": 30, "sensors": ["left"]}))  # same size
    os.utime(meta, ns=(stat.st_atime_ns, stat.st_mtime_ns))  # and same mtime: fps itself counts
    seen.add(_fingerprint(trial, "gelsight"))
    assert len(seen) == 2

    image = folder / "3.png"
    stat = image.stat()
    os.utime(image, ns=(stat.st_atime_ns, stat.st_mtime_ns + 10**9))  # an image rewritten
    seen.add(_fingerprint(trial, "gelsight"))
    assert len(seen) == 3

    (folder / TIMESTAMPS_NAME).write_text("t_s\n0\n1\n2\n3\n4\n")
    seen.add(_fingerprint(trial, "gelsight"))
    assert len(seen) == 4


# -- 4: fit memory and time are bounded ------------------------------------------------------

_MILLION_SAMPLES = textwrap.dedent(
    """
    import json, resource, time
    import numpy as np
    limit = 2 * 2**30
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    from liquidtouch.errors import SignalError
    from liquidtouch.fit.oscillation import fit_oscillation
    n = 1_000_000
    t = np.linspace(0.0, 13.0, n)
    rng = np.random.default_rng(0)
    u = np.exp(-0.35 * t) * np.cos(11.0 * t + 0.4) + 0.1 - 0.01 * t + rng.normal(0, 0.02, n)
    start = time.perf_counter()
    try:
        fit = fit_oscillation(t, u)
        outcome = ["fit", fit.decay_rate, fit.angular_frequency]
    except SignalError as exc:
        outcome = ["refused", str(exc)]
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps({"outcome": outcome, "seconds": time.perf_counter() - start,
                      "peak_mb": peak_mb}))
    """
)


def test_million_sample_fit_is_refused_cleanly_within_2_gib() -> None:
    # before: (22, 7, n, 5) profile grid: 1 M samples took 111 s and 7.8 GB
    proc = subprocess.run(
        [sys.executable, "-c", _MILLION_SAMPLES], capture_output=True, text=True, timeout=900
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    report = json.loads(proc.stdout.strip().splitlines()[-1])
    print(f"1 M samples under RLIMIT_AS 2 GiB: {report}")
    assert report["peak_mb"] < 2048
    kind, *rest = report["outcome"]
    if kind == "refused":
        assert "too long" in rest[0] and "resample" in rest[0] and len(rest[0]) < MESSAGE_LIMIT
        assert report["seconds"] < 5
    else:
        assert rest[0] == pytest.approx(0.35, rel=0.05) and rest[1] == pytest.approx(11.0, rel=0.01)


def test_fit_cli_refuses_more_samples_than_the_limit(tmp_path, capsys) -> None:
    n = MAX_SAMPLES + 1
    t = np.linspace(0.0, 60.0, n)
    path = tmp_path / "long.csv"
    np.savetxt(
        path,
        np.column_stack([t, np.cos(11 * t)]),
        fmt="%.6g",
        delimiter=",",
        header="t,u",
        comments="",
    )
    status, err = _run(capsys, "fit", path)
    assert status == 2 and f"at most {MAX_SAMPLES}" in _one_error_line(err)


def test_start_search_on_a_long_signal_is_thinned_and_chunked(monkeypatch) -> None:
    from liquidtouch.fit import model, start

    n = 1_000_000
    tau = np.linspace(0.0, 13.0, n)
    thinned = start.thin(tau, tau, band_high_rad_s=2 * np.pi * 5.0)
    assert thinned[0].size <= start.START_MAX_SAMPLES and thinned[0][-1] > 12.9
    u = np.exp(-0.35 * tau) * np.cos(11.0 * tau)
    assert start.spectral_peaks(tau, u, (2.0, 31.0), n_peaks=1)[0] == pytest.approx(11.0, rel=0.01)
    # a band reaching the Nyquist frequency is not thinned below 4× its top
    short = np.linspace(0.0, 13.0, 20_000)
    assert start.thin(short, band_high_rad_s=2 * np.pi * 600.0)[0].size == short.size
    # the profile grid in chunks equals the grid at once
    tau = np.linspace(0.0, 13.0, 500)
    drift, u, w = model.drift_columns(tau, 2), np.exp(-0.3 * tau) * np.cos(9.0 * tau), np.ones(500)
    whole = model.profile_cost_grid(tau, drift, u, w, start.RATE_GRID, np.array([8.5, 9.0, 9.5]))
    monkeypatch.setattr(model, "GRID_CHUNK_BYTES", 3 * 500 * 5 * 8 * 4)  # 4 rates per chunk
    chunked = model.profile_cost_grid(tau, drift, u, w, start.RATE_GRID, np.array([8.5, 9.0, 9.5]))
    np.testing.assert_allclose(chunked, whole, rtol=1e-12)


def test_correlated_errors_by_fft_match_the_lag_loop(monkeypatch) -> None:
    from liquidtouch.fit import solve

    rng = np.random.default_rng(0)
    g = rng.normal(size=(6000, 4))
    g = g + np.cumsum(g, axis=0) * 0.01
    fft = solve._newey_west_meat(g, 300)
    monkeypatch.setattr(solve, "FFT_MIN_SAMPLES", 10**9)
    loop = solve._newey_west_meat(g, 300)
    np.testing.assert_allclose(fft, loop, rtol=1e-9)


# -- 8: outputs are checked before the work and written only after it --------------------


@pytest.mark.parametrize("plot", ["fig.xyz", "figdir", "afile/fig.png"])
def test_extract_bad_plot_path_fails_before_the_work(tmp_path, capsys, plot: str) -> None:
    (tmp_path / "figdir").mkdir()
    (tmp_path / "afile").write_text("a file, not a folder")
    missing = tmp_path / "missing.mp4"  # reading it would be a different error
    status, err = _run(
        capsys, "extract", missing, "--plot", tmp_path / plot,
        "--signal-out", tmp_path / "u.csv", "--tracks-out", tmp_path / "tracks.npz",
    )  # fmt: skip
    assert status == 2 and "missing.mp4" not in _one_error_line(err)
    assert not (tmp_path / "u.csv").exists() and not (tmp_path / "tracks.npz").exists()


def test_extract_output_that_is_a_directory_fails_before_the_work(tmp_path, capsys) -> None:
    (tmp_path / "out").mkdir()
    for option in ("--signal-out", "--tracks-out"):
        status, err = _run(capsys, "extract", tmp_path / "missing.mp4", option, tmp_path / "out")
        assert status == 2 and "directory" in _one_error_line(err)


def test_extract_writes_no_output_when_a_later_step_fails(tmp_path, capsys, monkeypatch) -> None:
    import liquidtouch.extraction.plot

    video = _write_video(tmp_path / "left.mp4", _frames(150, 30.0), 30.0)

    def broken_plot(*args, **kwargs):
        raise OutputError("cannot draw the figure")

    monkeypatch.setattr(liquidtouch.extraction.plot, "plot_extraction", broken_plot)
    outputs = {"--signal-out": tmp_path / "u.csv", "--tracks-out": tmp_path / "t.npz"}
    args = [x for pair in outputs.items() for x in pair]
    status, err = _run(capsys, "extract", video, "--json", "--plot", tmp_path / "f.png", *args)
    assert status == 2 and "cannot draw" in _one_error_line(err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["left.mp4"]  # nothing, no temp files
    monkeypatch.undo()
    status, _ = _run(capsys, "extract", video, "--json", "--plot", tmp_path / "f", *args)
    assert status == 0
    assert (tmp_path / "f").read_bytes().startswith(b"\x89PNG")  # no suffix: PNG
    assert (tmp_path / "u.csv").is_file() and (tmp_path / "t.npz").is_file()


def test_fit_bad_plot_path_fails_before_the_fit(tmp_path, capsys, monkeypatch) -> None:
    import liquidtouch.fit.oscillation

    def no_fit(*args, **kwargs):
        raise AssertionError("the fit ran before --plot was checked")

    monkeypatch.setattr(liquidtouch.fit.oscillation, "fit_oscillation", no_fit)
    (tmp_path / "figdir").mkdir()
    for plot, reason in (("fit.xyz", "unknown figure format"), ("figdir", "directory")):
        status, err = _run(capsys, "fit", "--example", "--plot", tmp_path / plot)
        assert status == 2 and reason in _one_error_line(err)


# -- 9: CSV readers are bounded ---------------------------------------------------------------


def _one_line_csv(path: Path, columns: int = 3_000_000) -> Path:
    path.write_text("t,u," + ",".join(f"c{k}" for k in range(columns)))  # ~26 MB, one line
    return path


def test_one_line_csv_with_millions_of_columns_is_refused_fast(tmp_path, capsys) -> None:
    # before: 236 s, 9.2 GB and a 28.9 MB error line
    path = _one_line_csv(tmp_path / "wide.csv")
    start = time.perf_counter()
    status, err = _run(capsys, "fit", path)
    assert status == 2 and len(_one_error_line(err)) < MESSAGE_LIMIT + 10
    assert "header" in err
    with pytest.raises(TableError) as info:
        read_table(path)
    assert len(str(info.value)) < MESSAGE_LIMIT
    assert time.perf_counter() - start < 5


def test_csv_limits_size_header_length_and_columns(tmp_path) -> None:
    big = tmp_path / "big.csv"
    with big.open("wb") as handle:
        handle.write(b"t,u\n0,1\n")
        handle.truncate(MAX_CSV_BYTES + 1)  # sparse: nothing is written
    wide = tmp_path / "wide.csv"
    wide.write_text(
        ",".join(f"c{k}" for k in range(MAX_CSV_COLUMNS + 1)) + "\n" + "1," * 1000 + "1\n"
    )
    long = tmp_path / "long.csv"
    long.write_text("\n\n" + "x" * 100_000)
    for path, match in ((big, "MiB"), (wide, "columns"), (long, "header line")):
        for reader in (read_signal_csv, read_table):
            with pytest.raises(TableError, match=match) as info:
                reader(path)
            assert len(str(info.value)) < MESSAGE_LIMIT


def test_csv_error_messages_stay_short(tmp_path) -> None:
    many = tmp_path / "many.csv"
    names = [f"column_with_a_rather_long_name_{k}" for k in range(900)]
    many.write_text(",".join(names) + "\n" + ",".join("1" * 900) + "\n")
    cell = tmp_path / "cell.csv"
    cell.write_text("t,u\n0," + "x" * 1_000_000 + "\n")
    for path, match in ((many, "missing column"), (cell, "non-numeric")):
        with pytest.raises(TableError, match=match) as info:
            read_signal_csv(path)
        assert len(str(info.value)) < MESSAGE_LIMIT


# -- 13: truncated videos, the same video twice, rescaled and still signals -----------------


@pytest.mark.parametrize(
    ("name", "options"), [("cut.mkv", None), ("cut.mp4", {"movflags": "faststart"})]
)
def test_truncated_video_is_refused(tmp_path, capsys, name: str, options) -> None:
    # before: the frames decoded so far were used silently (λ +54 %)
    full = _write_video(tmp_path / f"full{Path(name).suffix}", _frames(150, 30.0), 30.0, options)
    assert sum(1 for _ in iter_video(full)) == 150
    cut = tmp_path / name
    data = full.read_bytes()
    cut.write_bytes(data[: int(len(data) * 0.6)])
    with pytest.raises(VideoError, match="cut short"):
        list(iter_video(cut))
    status, err = _run(capsys, "extract", cut, "--json")
    assert status == 2 and "cut short" in _one_error_line(err)


def test_the_same_video_twice_is_refused(tmp_path, capsys) -> None:
    video = _write_video(tmp_path / "left.mp4", _frames(40, 30.0), 30.0)
    (tmp_path / "link.mp4").symlink_to(video)
    for second in (video, tmp_path / "link.mp4", tmp_path / "." / "left.mp4"):
        status, err = _run(capsys, "extract", video, second)
        assert status == 2 and "same file" in _one_error_line(err)
    trial = tmp_path / "trial"
    trial.mkdir()
    shutil.copy(video, trial / "left.mp4")
    (trial / "meta.json").write_text(json.dumps({"fps": 30, "sensors": ["left.mp4", "./left.mp4"]}))
    status, err = _run(capsys, "extract", trial)
    assert status == 2 and "same file" in _one_error_line(err)


def test_flatness_is_relative_to_the_signal_s_scale() -> None:
    from liquidtouch.fit.example import example_signal

    t, u = example_signal()
    reference = fit_oscillation(t, u)
    for scale in (1e-15, 1e-150, 1e150):
        scaled = fit_oscillation(t, u * scale)  # before: u × 1e-15 was "flat"
        assert scaled.decay_rate == pytest.approx(reference.decay_rate, rel=1e-6)
        assert scaled.angular_frequency == pytest.approx(reference.angular_frequency, rel=1e-6)
        assert scaled.amplitude == pytest.approx(reference.amplitude * scale, rel=1e-6)
    for flat in (np.zeros_like(u), np.full_like(u, 3e-15), np.full_like(u, 7.0)):
        with pytest.raises(SignalError, match="flat"):
            fit_oscillation(t, flat)
    with pytest.raises(SignalError, match="flat"):
        fit_oscillation(t, 1e6 + 1e-9 * u)  # varies below float precision


def _lowpassed_noise(n: int, fps: float, seed: int) -> np.ndarray:
    from scipy.signal import butter, sosfiltfilt

    sos = butter(4, 3.0, fs=fps, output="sos")
    return sosfiltfilt(sos, np.random.default_rng(seed).normal(0.0, 0.02, n))


def test_no_push_found_in_a_still_signal() -> None:
    from liquidtouch.ring_down.segments import free_decay
    from liquidtouch.ring_down.start import MIN_PUSH_SNR, push_snr

    fps, n = 25.0, 325
    t = np.arange(n) / fps
    u = _lowpassed_noise(n, fps, seed=3)
    late = int(12.0 * fps)
    u[late] = 1.2 * np.abs(u).max()  # the largest noise excursion, 1 s before the end
    assert push_snr(t, u) < MIN_PUSH_SNR
    with pytest.raises(SignalError, match="no push found"):
        free_decay(t, u)
    # a real push late in the recording: the recording is too short after it
    u = _lowpassed_noise(n, fps, seed=3)
    u[late:] += 2.0 * np.exp(-0.5 * (t[late:] - t[late])) * np.cos(9.0 * (t[late:] - t[late]))
    assert push_snr(t, u) > 2 * MIN_PUSH_SNR
    with pytest.raises(SignalError, match="record at least 2 s after the push"):
        free_decay(t, u)


def test_still_video_is_reported_as_no_push(tmp_path, capsys) -> None:
    # before: "the free decay after the push lasts only 0.16 s"
    frames = _frames(13 * 25, 25.0, amplitude=0.0, noise=2.0)
    video = _write_video(tmp_path / "still.mp4", frames, 25.0)
    status, err = _run(capsys, "extract", video, "--json")
    assert status == 2
    assert "no push found" in _one_error_line(err) or "container was pushed" in err
