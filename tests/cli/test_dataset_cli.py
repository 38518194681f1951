"""``liquidtouch dataset init`` / ``add``: own recordings into a dataset, no JSON by hand.

End to end: a simulated trial's videos added with labels give, through
``features``, the λ and ω of the original trial's extraction. Every refused
input leaves the dataset exactly as it was.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from liquidtouch.cli import main
from liquidtouch.errors import DatasetError
from liquidtouch.io.dataset import read_manifest, read_trial_meta
from liquidtouch.io.dataset_dir import DATASET_MARKER, init_dataset
from liquidtouch.io.labels import check_labels
from liquidtouch.io.recordings import add_trial

LABELS = ("-l", "liquid=water", "-l", "height_mm=25", "-l", "container=grooved-cuboid")


def _run(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, str]:
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def _snapshot(root: Path) -> dict[str, bytes]:
    """Every file below ``root`` (hidden ones too) with its content."""
    return {
        str(p.relative_to(root)): p.read_bytes() if p.is_file() else b"<dir>"
        for p in sorted(root.rglob("*"))
    }


@pytest.fixture(scope="module")
def simulated(tmp_path_factory: pytest.TempPathFactory):
    """A simulated water trial (9 s, GelSight Mini videos) and its own extraction."""
    from liquidtouch.extraction.pipeline import extract_trial
    from liquidtouch.sim.trial import simulate_trial
    from liquidtouch.sim.trial_io import write_trial

    trial = simulate_trial("water", height_mm=25.0, seed=2, duration_s=9.0)
    directory = write_trial(trial, tmp_path_factory.mktemp("sim") / "trial", sensor="mini")
    return trial, directory, extract_trial(directory)


@pytest.fixture
def images(tmp_path: Path) -> Path:
    """A small image folder (synthetic marker dots; 61 frames: the fit's 2 s at 30 fps),
    without timestamps.csv."""
    from helpers import grid, render_blobs

    folder = tmp_path / "cam"
    folder.mkdir()
    import cv2

    points = grid((80, 100), pitch=20.0)
    for k in range(61):
        cv2.imwrite(str(folder / f"frame{k}.png"), render_blobs(points + 0.01 * k, (80, 100)))
    (folder / "notes.txt").write_text("not an image")
    return folder


def test_init_add_features_end_to_end(simulated, tmp_path: Path, capsys) -> None:
    trial, directory, original = simulated
    root = tmp_path / "mine"
    status, out, _ = _run(capsys, "dataset", "init", root)
    assert status == 0 and "dataset add" in out
    assert sorted(p.name for p in root.iterdir()) == [DATASET_MARKER]
    status, out, err = _run(
        capsys, "dataset", "add", root, directory / "left.mp4", directory / "right.mp4",
        *LABELS, "--split", "train", "--json",
    )  # fmt: skip
    assert status == 0, err
    doc = json.loads(out)
    assert doc["trial"] == "trial-0001" and doc["n_trials"] == 1 and doc["warnings"] == []
    assert doc["copied"] == 2 and doc["linked"] == 0
    meta = read_trial_meta(root / "trial-0001")
    assert meta.sensors == ["left.mp4", "right.mp4"]
    assert (meta.liquid, meta.height_mm, meta.container) == ("water", 25.0, "grooved-cuboid")
    assert meta.fps == pytest.approx(25.0, rel=0.03)  # the stream's average rate
    assert meta.true_decay_rate is None  # a recording: no ground truth
    # a second recording, hard-linked, nested name, another split
    status, out, err = _run(
        capsys, "dataset", "add", root, directory / "left.mp4", directory / "right.mp4",
        "-l", "liquid=water", "-l", "viscosity_cst=1.0", "--split", "test",
        "--name", "water/run2", "--link",
    )  # fmt: skip
    assert status == 0, err
    assert "added water/run2" in out and "lists 2 trial(s)" in out
    linked = root / "water" / "run2" / "left.mp4"
    assert linked.stat().st_ino == (directory / "left.mp4").stat().st_ino
    manifest = read_manifest(root)
    assert list(manifest["trial"]) == ["trial-0001", "water/run2"]
    assert list(manifest["split"]) == ["train", "test"]
    assert manifest["log10_viscosity_cst"].iloc[1] == 0.0
    assert np.isnan(manifest["height_mm"].iloc[1])

    from liquidtouch.batch.features import extract_features

    table = extract_features(root, progress=False).set_index("trial")
    assert (table["error"] == "").all()
    for trial_name in ("trial-0001", "water/run2"):
        row = table.loc[trial_name]
        assert row["decay_rate"] == pytest.approx(original["decay_rate"], rel=1e-9)
        assert row["angular_frequency"] == pytest.approx(original["angular_frequency"], rel=1e-9)
    assert row["angular_frequency"] == pytest.approx(trial.true_angular_frequency, rel=0.02)
    assert table.loc["trial-0001", "height_mm"] == 25.0


def test_image_folders_need_a_frame_rate(images: Path, tmp_path: Path, capsys) -> None:
    root = init_dataset(tmp_path / "data")
    status, _, err = _run(capsys, "dataset", "add", root, images, "-l", "liquid=water")
    assert status == 2 and "--fps" in err and "timestamps.csv" in err
    added = add_trial(root, [images], fps=30.0, sensor_names=["left"])
    assert added.fps == 30.0 and added.sensors == ["left"]
    copied = sorted(p.name for p in (added.path / "left").iterdir())
    assert copied == sorted(f"frame{k}.png" for k in range(61))  # images only
    # with timestamps.csv the folder times itself; meta.json gets its rate
    (images / "timestamps.csv").write_text("t_s\n" + "".join(f"{k * 0.05}\n" for k in range(61)))
    added = add_trial(root, [images])
    assert added.fps == pytest.approx(20.0) and added.trial == "trial-0002"
    # its length is judged on its own clock, not on a `fps` that disagrees with it
    assert add_trial(root, [images], fps=1000.0, name="fast").fps == 1000.0
    assert (added.path / "cam" / "timestamps.csv").is_file()
    assert read_manifest(root)["trial"].tolist() == ["trial-0001", "trial-0002", "fast"]
    # the same 61 frames over 1.2 s (or 6 of them): no fit can come from them, refused now
    (images / "timestamps.csv").write_text("t_s\n" + "".join(f"{k * 0.02}\n" for k in range(61)))
    status, _, err = _run(capsys, "dataset", "add", root, images, "-l", "liquid=water")
    assert status == 2 and "holds 61 frames over 1.2 s; the fit needs at least 20" in err, err
    for k in range(6, 61):
        (images / f"frame{k}.png").unlink()
    (images / "timestamps.csv").unlink()
    status, _, err = _run(capsys, "dataset", "add", root, images, "--fps", "2")
    assert status == 2 and "holds 6 frames over 2.5 s; the fit needs at least 20" in err, err
    assert read_manifest(root)["trial"].tolist() == ["trial-0001", "trial-0002", "fast"]


def test_init_refuses_existing_things(tmp_path: Path, capsys) -> None:
    root = init_dataset(tmp_path / "a")
    for target, message in (
        (root, "already a dataset"),
        (tmp_path / "file", "not a directory"),
        (tmp_path / "full", "not empty"),
    ):
        if target.name == "file":
            target.write_text("x")
        if target.name == "full":
            target.mkdir()
            (target / "video.mp4").write_text("x")
        status, _, err = _run(capsys, "dataset", "init", target)
        assert status == 2 and message in err, err
    empty = tmp_path / "empty"
    empty.mkdir()
    assert init_dataset(empty) == empty


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (("-l", "liquid=water", "-l", "heigth_mm=25"), "did you mean height_mm"),
        (("-l", "height_mm=tall"), "must be a number"),
        (("-l", "height_mm=-3"), "must be > 0"),
        (("-l", "height_mm=nan"), "finite"),
        (("-l", "sugar_concentration=-1"), ">= 0"),
        (("-l", "temperature_c=-300"), "absolute zero"),
        (("-l", "liquid=Olive Oil"), "use --label liquid=olive-oil"),
        (("-l", "liquid=Tea"), "use --label liquid=tea"),  # "tea" is already in the manifest
        (("-l", "liquid"), "must be KEY=VALUE"),
        (("-l", "liquid="), "is empty"),
        (("-l", "liquid=a", "-l", "liquid=b"), "given twice"),
        (("-l", "viscosity_cst=10", "-l", "log10_viscosity_cst=2"), "disagree"),
        (("--name", "first"), "already lists trial 'first'"),
        (("--name", "first/inner"), "nest"),
        (("--name", "../out"), "trial name"),
        (("--name", ".hidden"), "trial name"),
        (("--name", "features.csv"), "reserved"),
        (("--split", "train set"), "split"),
        (("--fps", "0"), "positive"),
        (("--sensor-name", "left"), "1 sensor name(s) for 2 input(s)"),
        (("--sensor-name", "a", "--sensor-name", "a"), "must differ"),
        (("--topic", "/x"), "--topic goes with --bag"),
        (("--markers", "m.csv"), "got files and markers"),
    ],
)
def test_add_refuses_bad_input_and_changes_nothing(
    simulated, tmp_path: Path, capsys, extra: tuple[str, ...], message: str
) -> None:
    _, directory, _ = simulated
    root = init_dataset(tmp_path / "data")
    add_trial(root, [directory / "left.mp4"], labels={"liquid": "tea"}, name="first")
    before = _snapshot(root)
    videos = (directory / "left.mp4", directory / "right.mp4")
    status, out, err = _run(capsys, "dataset", "add", root, *videos, *extra)
    assert status == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and message in lines[0], err
    assert _snapshot(root) == before


def test_add_refuses_bad_sources(simulated, images: Path, tmp_path: Path, capsys) -> None:
    _, directory, _ = simulated
    root = init_dataset(tmp_path / "data")
    before = _snapshot(root)
    fake = tmp_path / "fake.mp4"
    fake.write_bytes(b"not a video" * 50)
    cases = [
        ((fake,), "cannot read video"),
        ((tmp_path / "missing.mp4",), "does not exist"),
        ((directory,), "is a trial directory"),
        ((directory / "left.mp4", directory / "left.mp4"), "same recording"),
        ((), "give the recording as video files"),
        ((tmp_path / "nowhere",), "does not exist"),
        ((images / "frame0.png",), "is one image"),
        ((tmp_path,), "holds no images"),
    ]
    for sources, message in cases:
        status, _, err = _run(capsys, "dataset", "add", root, *sources, "-l", "liquid=water")
        assert status == 2 and message in err, (sources, err)
    status, _, err = _run(capsys, "dataset", "add", tmp_path / "nodata", directory / "left.mp4")
    assert status == 2 and "dataset init" in err
    assert _snapshot(root) == before


def test_failed_manifest_write_rolls_the_trial_back(simulated, tmp_path, monkeypatch) -> None:
    _, directory, _ = simulated
    from liquidtouch.io import recordings

    root = init_dataset(tmp_path / "data")
    add_trial(root, [directory / "left.mp4"], name="kept")
    before = _snapshot(root)

    def broken(*args, **kwargs):
        raise KeyboardInterrupt  # Ctrl-C (or a full disk) while the manifest is written

    monkeypatch.setattr(recordings, "append_manifest_row", broken)
    with pytest.raises(KeyboardInterrupt):
        add_trial(root, [directory / "left.mp4"], name="lost")
    assert _snapshot(root) == before


def test_link_falls_back_to_copy(simulated, tmp_path: Path, monkeypatch) -> None:
    _, directory, _ = simulated
    root = init_dataset(tmp_path / "data")

    def cross_device(src, dst, *args, **kwargs):
        raise OSError(18, "Invalid cross-device link")

    monkeypatch.setattr(os, "link", cross_device)
    added = add_trial(root, [directory / "left.mp4"], link=True)
    assert (added.linked, added.copied) == (0, 1)
    assert any("could not be hard-linked" in w for w in added.warnings)
    assert (added.path / "left.mp4").read_bytes() == (directory / "left.mp4").read_bytes()


def test_add_to_a_simulated_dataset_keeps_its_rows(simulated, tmp_path: Path) -> None:
    """A manifest written elsewhere (extra columns, integers) keeps its rows byte for byte."""
    _, directory, _ = simulated
    root = tmp_path / "sim"
    shutil.copytree(directory, root / "train" / "t0")
    text = "trial,split,liquid,seed,true_decay_rate\ntrain/t0,train,water,7,0.25\n"
    (root / "manifest.csv").write_text(text)
    added = add_trial(root, [directory / "right.mp4"], labels={"liquid": "water"}, split="test")
    lines = (root / "manifest.csv").read_text().splitlines()
    assert lines[0].startswith("trial,split,liquid,seed,true_decay_rate,container,height_mm")
    assert lines[1].startswith("train/t0,train,water,7,0.25,,")
    assert lines[2].startswith(f"{added.trial},test,water,,,")
    assert (root / DATASET_MARKER).is_file()  # marked (and locked) on the first add


def test_labels_are_checked_and_viscosity_derived() -> None:
    labels, warnings = check_labels({"liquid": "honey", "viscosity_cst": "100"})
    assert labels["log10_viscosity_cst"] == pytest.approx(2.0)
    assert labels["liquid"] == "honey" and "not in the simulator's catalogue" in warnings[0]
    labels, warnings = check_labels({"log10_viscosity_cst": 1.5, "liquid": "mirin"})
    assert labels["viscosity_cst"] == pytest.approx(10**1.5) and warnings == []
    labels, _ = check_labels({"viscosity_cst": "10", "log10_viscosity_cst": "1.0004"})
    assert labels["log10_viscosity_cst"] == 1.0004  # agrees within 1e-3: kept as given
    with pytest.raises(DatasetError, match="unknown label 'split'"):
        check_labels({"split": "train"})
    with pytest.raises(DatasetError, match="container 'Grooved Cuboid' differs"):
        check_labels({"container": "Grooved Cuboid"})


def test_dataset_help(capsys) -> None:
    for command in (["dataset"], ["dataset", "init"], ["dataset", "add"]):
        assert main([*command, "--help"]) == 0
        out = capsys.readouterr().out
        assert out.startswith("Usage: liquidtouch " + " ".join(command))
    assert main(["dataset", "add", "--help"]) == 0
    assert "Frame rate [Hz]" in " ".join(capsys.readouterr().out.split())


@pytest.mark.parametrize("name", ["manifest.csv/x", "features.csv/x", "tables.csv", "meta.json/a"])
def test_names_of_the_datasets_own_files_are_refused(simulated, tmp_path, capsys, name) -> None:
    """Campaign: a failed `--name manifest.csv/x` left a manifest.csv/ folder (every later
    add failed); `--name features.csv/x` was accepted and broke `features`."""
    _, directory, _ = simulated
    root = init_dataset(tmp_path / "data")
    before = _snapshot(root)
    status, _, err = _run(capsys, "dataset", "add", root, directory / "left.mp4", "--name", name)
    assert status == 2 and "is reserved for the dataset's own files" in err, err
    assert _snapshot(root) == before
    assert add_trial(root, [directory / "left.mp4"]).n_trials == 1


def test_a_failed_add_removes_the_folders_it_made(simulated, tmp_path, monkeypatch) -> None:
    _, directory, _ = simulated
    from liquidtouch.io import recordings

    root = init_dataset(tmp_path / "data")
    before = _snapshot(root)

    def broken(*args, **kwargs):
        raise DatasetError("disk full")

    monkeypatch.setattr(recordings, "append_manifest_row", broken)
    with pytest.raises(DatasetError):
        add_trial(root, [directory / "left.mp4"], name="water/deep/h25")
    assert _snapshot(root) == before


def test_frames_are_checked_at_add_time_like_extract_does(tmp_path, capsys) -> None:
    """36 001 images (over the 36 000 frames tracked), empty images, PNGs of two sizes:
    refused by `add` (they used to be added and then refused by `features`)."""
    import cv2

    root = init_dataset(tmp_path / "data")
    before = _snapshot(root)
    many = tmp_path / "many"
    many.mkdir()
    for k in range(36_001):
        (many / f"{k:06d}.png").touch()
    empty = tmp_path / "empty"
    empty.mkdir()
    for k in range(3):
        (empty / f"{k}.png").touch()
    sizes = tmp_path / "sizes"
    sizes.mkdir()
    cv2.imwrite(str(sizes / "0.png"), np.zeros((20, 30), np.uint8))
    cv2.imwrite(str(sizes / "1.png"), np.zeros((20, 40), np.uint8))
    cases = [
        (many, "holds 36001 frames, more than the 36000"),
        (empty, "is empty (0 bytes)"),
        (sizes, "1.png is 40x20 but 0.png is 30x20"),
    ]
    for folder, message in cases:
        status, _, err = _run(capsys, "dataset", "add", root, folder, "--fps", "30")
        assert status == 2 and message in err, err
    assert _snapshot(root) == before


def test_link_of_a_symlinked_video_and_the_reason_a_link_failed(
    simulated, tmp_path: Path, monkeypatch, capsys
) -> None:
    _, directory, _ = simulated
    root = init_dataset(tmp_path / "data")
    alias = tmp_path / "alias.mp4"
    alias.symlink_to(directory / "left.mp4")
    status, _, err = _run(capsys, "dataset", "add", root, alias, "--link", "--name", "a")
    assert status == 0, err
    assert not (root / "a" / "alias.mp4").is_symlink()
    assert (root / "a" / "alias.mp4").stat().st_ino == (directory / "left.mp4").stat().st_ino

    def too_many_links(src, dst, *args, **kwargs):
        raise OSError(31, "Too many links")

    monkeypatch.setattr(os, "link", too_many_links)
    added = add_trial(root, [directory / "left.mp4"], link=True, name="b")
    assert any("hard-link limit" in w for w in added.warnings), added.warnings
    assert not any("another file system" in w for w in added.warnings)
