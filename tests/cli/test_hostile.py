"""Hostile but realistic inputs: one clear ``error:`` line and exit 2, never a traceback,
never a silently wrong number, never a corrupted output; a batch survives a bad trial.

Organised by what is attacked: trial metadata, batch extraction, outputs.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from liquidtouch._core import atomic
from liquidtouch._core.pool import open_executor
from liquidtouch.batch.features import CACHE_DIR, extract_features
from liquidtouch.cli import main
from liquidtouch.errors import DatasetError, LiquidTouchError, OutputError
from liquidtouch.io.dataset import read_trial_meta, write_manifest


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str]:
    status = main(list(argv))
    err = capsys.readouterr().err
    return status, err


def _meta(trial: Path, **fields: object) -> Path:
    trial.mkdir(parents=True, exist_ok=True)
    (trial / "meta.json").write_text(json.dumps({"fps": 30, "sensors": [], **fields}))
    return trial


# -- trial metadata ------------------------------------------------------------------------


@pytest.mark.parametrize("fps", [-30, 0, "NaN", "Infinity"])
def test_meta_fps_must_be_a_positive_finite_rate(tmp_path: Path, fps: object) -> None:
    trial = tmp_path / "t"
    trial.mkdir()
    text = json.dumps({"fps": fps, "sensors": []}).replace('"NaN"', "NaN")
    (trial / "meta.json").write_text(text.replace('"Infinity"', "Infinity"))
    with pytest.raises(DatasetError, match="fps"):
        read_trial_meta(trial)


def test_meta_format_version_as_a_string_is_refused(tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match="format_version"):
        read_trial_meta(_meta(tmp_path / "t", format_version="2"))


def test_meta_nested_deeply_is_a_dataset_error(tmp_path: Path) -> None:
    trial = tmp_path / "t"
    trial.mkdir()
    (trial / "meta.json").write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(DatasetError, match="nested too deeply"):
        read_trial_meta(trial)


def test_sensor_symlink_leading_outside_the_trial_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    outside = tmp_path / "secret.txt"
    outside.write_text("not yours")
    trial = _meta(tmp_path / "t", sensors=["x.mp4"])
    (trial / "x.mp4").symlink_to(outside)
    with pytest.raises(DatasetError, match="inside the trial directory"):
        read_trial_meta(trial)
    status, err = _run(capsys, "extract", str(trial))
    assert status == 2 and err.startswith("error: ") and "inside the trial" in err


# -- batch extraction ----------------------------------------------------------------------


@pytest.fixture
def wrench_dataset(tmp_path: Path) -> Path:
    """Three trials with wrist F/T data only (fast): one good-looking, two hostile."""
    from liquidtouch.sim.trial import simulate_trial
    from liquidtouch.sim.trial_io import write_trial

    root = tmp_path / "data"
    write_trial(simulate_trial("olive-oil", height_mm=30.0, seed=1), root / "good", video=False)
    nested = _meta(root / "nested")
    (nested / "meta.json").write_text("[" * 100_000 + "]" * 100_000)
    unreadable = _meta(root / "unreadable")
    (unreadable / "meta.json").write_bytes(b"\xff\xfe\x00garbage")
    write_manifest(root, [{"trial": name} for name in ("good", "nested", "unreadable")])
    return root


def test_one_bad_trial_never_kills_the_batch(wrench_dataset: Path) -> None:
    table = extract_features(wrench_dataset, source="wrench", progress=False).set_index("trial")
    assert list(table.index) == ["good", "nested", "unreadable"]
    assert "nested too deeply" in table.loc["nested", "error"]
    assert "not valid JSON" in table.loc["unreadable", "error"]
    assert (wrench_dataset / "features.csv").is_file()


def test_a_damaged_cache_entry_is_recomputed(wrench_dataset: Path) -> None:
    first = extract_features(wrench_dataset, source="wrench", progress=False)
    cache = wrench_dataset / CACHE_DIR / "wrench" / "good.json"
    assert cache.is_file()
    for damage in ("null", "[1, 2]", '{"fingerprint": 3'):
        cache.write_text(damage)
        again = extract_features(wrench_dataset, source="wrench", progress=False)
        assert again.loc[0, "error"] == first.loc[0, "error"]
        assert again.loc[0, "decay_rate"] == pytest.approx(first.loc[0, "decay_rate"], nan_ok=True)


def test_dask_address_that_is_not_one() -> None:
    with pytest.raises(LiquidTouchError, match="Dask scheduler"):
        with open_executor(1, "not-a-url"):
            pass


def test_workers_are_capped_at_cores_and_tasks() -> None:
    with open_executor(200, n_tasks=2) as pool:
        assert pool._max_workers == min(2, os.cpu_count() or 1)


# -- outputs -------------------------------------------------------------------------------


def test_output_that_is_a_directory(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(OutputError, match="is a directory"):
        atomic.write_text(tmp_path, "x")
    status, err = _run(capsys, "fit", "--example", "--plot", str(tmp_path))
    assert status == 2 and err.startswith("error: ") and "directory" in err


def test_output_under_a_file(tmp_path: Path) -> None:
    parent = tmp_path / "file"
    parent.write_text("x")
    with pytest.raises(OutputError, match="cannot write"):
        atomic.write_text(parent / "out.csv", "x")


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only directories")
def test_output_in_a_read_only_directory(tmp_path: Path) -> None:
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        with pytest.raises(OutputError, match="Permission denied"):
            atomic.write_text(ro / "out.csv", "x")
    finally:
        ro.chmod(0o700)


def test_full_disk_leaves_nothing_behind(tmp_path: Path) -> None:
    if not Path("/dev/full").exists():
        pytest.skip("no /dev/full on this system")
    target = tmp_path / "out.csv"
    with pytest.raises(OutputError, match="No space left"):
        with (
            atomic.atomic_path(target) as tmp,
            open(tmp, "wb") as fh,
            open("/dev/full", "wb") as full,
        ):
            fh.write(b"partial")
            full.write(b"x" * 65536)
            full.flush()
    assert not target.exists() and list(tmp_path.iterdir()) == []


def test_a_recording_far_longer_than_a_trial_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    from helpers import grid, render_blobs

    from liquidtouch.errors import VideoError
    from liquidtouch.tracking import tracks

    monkeypatch.setattr(tracks, "MAX_FRAMES", 5)
    image = render_blobs(grid())
    frames = ((k / 30.0, image) for k in range(10))
    with pytest.raises(VideoError, match="more than the 5 tracked"):
        tracks.track_markers(frames)
    assert tracks.track_markers((k / 30.0, image) for k in range(5)).positions.shape[0] == 5


def test_simulate_dataset_checks_the_sensor_before_writing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "data"
    argv = ["simulate", "dataset", "--preset", "sugar", "--quick", "--sensor", "bogus"]
    status, err = _run(capsys, *argv, "-o", str(out))
    assert status == 2 and err.startswith("error: unknown sensor 'bogus'") and not out.exists()


def test_a_folder_without_images_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "data" / "sub").mkdir(parents=True)
    status, err = _run(capsys, "extract", str(tmp_path / "data"))
    assert status == 2 and "holds no images" in err
