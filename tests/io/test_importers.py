"""Importers: GelSight marker CSVs → MarkerTracks → trial ``tracks.npz``; ROS bags → image folders.

End to end on a simulated trial (GelSight Mini videos and the renderer's
ground-truth marker positions, ``truth_tracks.npz``): the truth written as a
marker CSV and imported gives λ, ω close to the simulator's truth; the videos'
frames written to a ROS 2 bag and imported give the same λ, ω as the videos.
"""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from liquidtouch.cli import main
from liquidtouch.errors import DatasetError, TableError, VideoError
from liquidtouch.io.marker_csv import read_marker_csv
from liquidtouch.io.rosbag import topic_sensor_names
from liquidtouch.io.trial_tracks import TRACKS_NAME, read_trial_tracks, stored_tracks

EPOCH_NS = 1_700_000_000_000_000_000


def _run(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, str]:
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


@pytest.fixture(scope="module")
def simulated(tmp_path_factory: pytest.TempPathFactory):
    """A clean simulated water trial (9 s, GelSight Mini videos) and its video extraction."""
    from liquidtouch.extraction.pipeline import extract
    from liquidtouch.sim.trial import simulate_trial
    from liquidtouch.sim.trial_io import write_trial
    from liquidtouch.sim.variability import Variability

    trial = simulate_trial(
        "water", height_mm=25.0, seed=1, duration_s=9.0, variability=Variability.none()
    )
    directory = write_trial(trial, tmp_path_factory.mktemp("sim") / "trial", sensor="mini")
    return trial, directory, extract(directory).fit


def _write_truth_csv(truth: Path, out: Path, *, header: bool) -> list[Path]:
    """The renderer's marker positions as GelSight marker CSVs, one per sensor."""
    with np.load(truth) as z:
        pos, frame_index, times = z["positions_px"], z["frame_index"], z["timestamps_s"]
        sensors = [str(s) for s in z["sensors"]]
    paths = []
    for s, sensor in enumerate(sensors):
        lines = ["frame,row,col,Ox,Oy,Cx,Cy,t_s"] if header else []
        for k in range(len(frame_index)):
            for m in range(pos.shape[2]):
                r, c = divmod(m, 11)
                x0, y0 = pos[s, 0, m]
                x, y = pos[s, k, m]
                if header:
                    row = f"{frame_index[k] + 1},{r},{c},{x0:.3f},{y0:.3f},{x:.3f},{y:.3f}"
                    lines.append(f"{row},{times[k]:.6f}")
                else:  # as the GelSight SDK's demo writes it
                    lines.append(
                        f"{frame_index[k] + 1:6d}, {r:3d}, {c:3d}, {x0:6.2f}, {y0:6.2f}, "
                        f"{x:6.2f}, {y:6.2f}"
                    )
        path = out / f"{sensor}.csv"
        path.write_text("\n".join(lines) + "\n")
        paths.append(path)
    return paths


# -- marker CSV ------------------------------------------------------------------------------


def test_gelsight_csv_without_header(tmp_path: Path) -> None:
    rows = []
    for frame in (1, 2, 4):  # frame 3 was dropped
        for r in range(2):
            for c in range(3):
                if frame == 2 and (r, c) == (1, 2):
                    continue  # this marker is missing from frame 2: lost
                x0, y0 = 10.0 + 30 * c, 5.0 + 30 * r
                rows.append(
                    f"{frame:6d}, {r:3d}, {c:3d}, {x0:6.2f}, {y0:6.2f}, "
                    f"{x0 + frame:6.2f}, {y0 - frame:6.2f}"
                )
    path = tmp_path / "marker_locations_0.csv"
    path.write_text("\n".join(rows[::-1]) + "\n\n")  # any row order
    tracks = read_marker_csv(path, fps=10.0)
    assert tracks.sensor == "marker_locations_0"
    np.testing.assert_allclose(tracks.t, [0.0, 0.1, 0.3])
    assert tracks.positions.shape == (3, 6, 2) and tracks.n_markers == 6
    np.testing.assert_allclose(tracks.reference[1], [40.0, 5.0])  # (row 0, col 1)
    np.testing.assert_allclose(tracks.positions[2, 1], [44.0, 1.0])
    assert not tracks.valid[1, 5] and np.isnan(tracks.positions[1, 5]).all()
    assert tracks.valid.sum() == 17
    assert tracks.spacing_px == pytest.approx(30.0)


def test_csv_with_header_aliases_and_times(tmp_path: Path) -> None:
    path = tmp_path / "left.csv"
    path.write_text(
        "Frame, Row, Col, Cx, Cy, t_s\n"
        "0, 0, 0, 1.0, 2.0, 100.00\n0, 0, 1, 5.0, 2.0, 100.00\n"
        "1, 0, 0, 1.5, 2.0, 100.04\n1, 0, 1, , 2.0, 100.04\n"
        "2, 0, 0, 2.0, 2.0, 100.09\n2, 0, 1, 6.0, nan, 100.09\n"
    )
    tracks = read_marker_csv(path, fps=1000.0, sensor="L")  # t_s wins over fps
    assert tracks.sensor == "L"
    np.testing.assert_allclose(tracks.t, [0.0, 0.04, 0.09])
    np.testing.assert_allclose(tracks.reference, [[1.0, 2.0], [5.0, 2.0]])  # first positions
    assert tracks.valid.tolist() == [[True, True], [True, False], [True, False]]


GOOD = "1,0,0,1,2,1,2\n1,0,1,5,2,5,2\n2,0,0,1,2,1,2\n2,0,1,5,2,5,2\n"
TIMED = "frame,row,col,x,y,t_s\n1,0,0,1,2,0\n2,0,0,1,2,1\n"


@pytest.mark.parametrize(
    ("text", "fps", "message"),
    [
        (GOOD, None, "pass `fps`"),
        ("1, 0, 0, 1, 2, 1\n", 30.0, "has 7 columns"),
        ("frame,row,x,y\n1,0,1,2\n", 30.0, "lacks column(s) col"),
        (GOOD + "1,0,1,5,2,5,2\n", 30.0, "(row 0, col 1) appears twice in frame 1"),
        (GOOD + "3,0,zero,1,2,1,2\n", 30.0, "column col must hold numbers"),
        (GOOD + "3.5,0,0,1,2,1,2\n", 30.0, "whole numbers"),
        (GOOD + "3,0,0,1,2,1,inf\n", 30.0, "column y must hold numbers"),
        ("1,0,0,1,2,1,2\n1,0,1,9,2,9,2\n", 30.0, "1 frame(s)"),
        ("1,0,0,1,2,1,2\n2,0,0,1,2,1,2\n", 30.0, "fewer than 2 markers"),
        (TIMED + "1,0,1,5,2,0.5\n", None, "different t_s"),
        (TIMED + "1,0,1,5,2,0\n3,0,0,1,2,0.5\n", None, "must increase"),
        ("", 30.0, "is empty"),
    ],
)
def test_bad_marker_csv_is_refused(tmp_path: Path, text: str, fps, message: str) -> None:
    path = tmp_path / "m.csv"
    path.write_text(text)
    with pytest.raises(TableError) as info:
        read_marker_csv(path, fps=fps)
    assert message in str(info.value)


def test_truth_tracks_as_gelsight_csv_give_the_true_decay(simulated, tmp_path: Path, capsys):
    trial, directory, _ = simulated
    root = tmp_path / "data"
    assert _run(capsys, "dataset", "init", root)[0] == 0
    csvs = _write_truth_csv(directory / "truth_tracks.npz", tmp_path, header=True)
    status, out, err = _run(
        capsys, "dataset", "add", root, *[f"--markers={p}" for p in csvs],
        "--label", "liquid=water", "--label", "height_mm=25", "--name", "imported", "--json",
    )  # fmt: skip
    assert status == 0, err
    doc = json.loads(out)
    assert doc["kind"] == "markers" and doc["sensors"] == ["left", "right"]
    trial_dir = root / "imported"
    assert sorted(p.name for p in trial_dir.iterdir()) == ["meta.json", TRACKS_NAME]
    meta = json.loads((trial_dir / "meta.json").read_text())
    assert meta["sensors"] == [] and meta["tracks"] == TRACKS_NAME
    assert meta["fps"] == pytest.approx(24.6, abs=0.2)  # the rate of the t_s column
    tracks = read_trial_tracks(trial_dir)
    assert [tr.sensor for tr in tracks] == ["left", "right"] and tracks[0].n_markers == 77

    from liquidtouch.batch.features import extract_features

    row = extract_features(root, progress=False).set_index("trial").loc["imported"]
    assert row["error"] == ""
    # the renderer's positions (no tracking noise) on the real frame times:
    # measured ω −0.001 %, λ +2.5 %
    assert row["angular_frequency"] == pytest.approx(trial.true_angular_frequency, rel=0.005)
    assert row["decay_rate"] == pytest.approx(trial.true_decay_rate, rel=0.06)

    # the SDK's headerless layout, timed by --fps (the camera's mean rate)
    csvs = _write_truth_csv(directory / "truth_tracks.npz", tmp_path, header=False)
    with np.load(directory / "truth_tracks.npz") as z:
        rate = z["frame_index"][-1] / z["timestamps_s"][-1]
    status, out, err = _run(
        capsys, "dataset", "add", root, "--markers", csvs[0], "--markers", csvs[1],
        "--fps", rate, "--label", "liquid=water", "--json",
    )  # fmt: skip
    assert status == 0, err
    status, out, err = _run(capsys, "extract", root / json.loads(out)["trial"], "--json")
    assert status == 0, err
    fit = json.loads(out)
    assert fit["angular_frequency"] == pytest.approx(trial.true_angular_frequency, rel=0.01)
    assert fit["decay_rate"] == pytest.approx(trial.true_decay_rate, rel=0.1)


def test_stored_tracks_select_sensors_and_refuse_damage(simulated, tmp_path: Path) -> None:
    _, directory, _ = simulated
    from liquidtouch.io.dataset_dir import init_dataset
    from liquidtouch.io.recordings import add_trial

    root = init_dataset(tmp_path / "data")
    csvs = _write_truth_csv(directory / "truth_tracks.npz", tmp_path, header=True)
    added = add_trial(root, markers=csvs)
    assert stored_tracks(directory) is None  # a video trial: tracked as usual
    assert stored_tracks([added.path, added.path]) is None
    assert [t.sensor for t in stored_tracks(added.path, ["right"])] == ["right"]
    with pytest.raises(VideoError, match="no sensor 'middle'"):
        stored_tracks(added.path, ["middle"])
    (added.path / TRACKS_NAME).write_bytes(b"not an npz")
    with pytest.raises(DatasetError, match="not a readable tracks file"):
        read_trial_tracks(added.path)
    meta = json.loads((added.path / "meta.json").read_text())
    (added.path / "meta.json").write_text(json.dumps({**meta, "tracks": "../escape.npz"}))
    with pytest.raises(DatasetError, match="inside"):
        read_trial_tracks(added.path)


# -- ROS bags --------------------------------------------------------------------------------


def _typestore(ros1: bool = False):
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)


def _image_msg(store, image: np.ndarray, encoding: str, stamp_ns: int):
    import cv2

    types = store.types
    header_type = types["std_msgs/msg/Header"]
    fields = {"stamp": _time(store, stamp_ns), "frame_id": "gelsight"}
    if "seq" in header_type.__dataclass_fields__:  # ROS 1
        fields["seq"] = 0
    header = header_type(**fields)
    if encoding in ("jpeg", "png"):
        ok, data = cv2.imencode(f".{encoding}", image)
        assert ok
        return types["sensor_msgs/msg/CompressedImage"](
            header=header, format=encoding, data=data.ravel()
        )
    image = np.ascontiguousarray(image)
    return types["sensor_msgs/msg/Image"](
        header=header,
        height=image.shape[0],
        width=image.shape[1],
        encoding=encoding,
        is_bigendian=0,
        step=image.strides[0],
        data=image.ravel().view(np.uint8),
    )


def _time(store, ns: int):
    return store.types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)


def write_bag(path: Path, streams: dict[str, tuple[str, list]], *, ros1: bool = False) -> Path:
    """A bag of image topics: ``{topic: (encoding, [(stamp_ns, bag_ns, image), ...])}``."""
    store = _typestore(ros1)
    if ros1:
        from rosbags.rosbag1 import Writer

        serialize = store.serialize_ros1
        writer = Writer(path)
    else:
        from rosbags.rosbag2 import Writer

        serialize = store.serialize_cdr
        writer = Writer(path, version=9)
    with writer:
        for topic, (encoding, frames) in streams.items():
            compressed = encoding in ("jpeg", "png")
            msgtype = "sensor_msgs/msg/" + ("CompressedImage" if compressed else "Image")
            connection = writer.add_connection(topic, msgtype, typestore=store)
            for stamp_ns, bag_ns, image in frames:
                msg = _image_msg(store, image, encoding, stamp_ns)
                writer.write(connection, bag_ns, serialize(msg, msgtype))
    return path


def _dots(k: int, shape=(60, 80)) -> np.ndarray:
    from helpers import render_blobs

    pts = np.array([[20.0 + 20 * i, 20.0 + 20 * j] for i in range(3) for j in range(2)])
    return render_blobs(pts + np.array([0.5 * k, 0.0]), shape=shape, radius=3.0)


def test_ros2_bag_of_simulated_frames_gives_the_videos_features(simulated, tmp_path, capsys):
    pytest.importorskip("rosbags")
    from liquidtouch.io.frames import iter_video

    _, directory, video_fit = simulated
    streams = {}
    for side, encoding in (("left", "mono8"), ("right", "bgr8")):
        frames = []
        for t, image in iter_video(directory / f"{side}.mp4"):
            stamp = EPOCH_NS + round(t * 1e9) + (5_000_000 if side == "right" else 0)
            if encoding == "bgr8":
                image = np.repeat(image[:, :, None], 3, axis=2)
            frames.append((stamp, stamp + 2_000_000, image))
        streams[f"/gelsight/{side}/image_raw"] = (encoding, frames)
    bag = write_bag(tmp_path / "run", streams)
    root = tmp_path / "data"
    assert _run(capsys, "dataset", "init", root)[0] == 0
    status, out, err = _run(
        capsys, "dataset", "add", root, "--bag", bag,
        "--topic", "/gelsight/left/image_raw", "--topic", "/gelsight/right/image_raw",
        "-l", "liquid=water", "-l", "height_mm=25", "--split", "test", "--json",
    )  # fmt: skip
    assert status == 0, err
    doc = json.loads(out)
    assert doc["kind"] == "rosbag" and doc["sensors"] == ["left", "right"]
    trial_dir = Path(doc["path"])
    meta = json.loads((trial_dir / "meta.json").read_text())
    assert meta["sensors"] == ["left", "right"]
    assert meta["source"]["topics"] == ["/gelsight/left/image_raw", "/gelsight/right/image_raw"]
    n = len(streams["/gelsight/left/image_raw"][1])
    left = sorted((trial_dir / "left").glob("*.png"))
    assert len(left) == n and left[0].name == "000000.png"
    import pandas as pd

    stamps = pd.read_csv(trial_dir / "right" / "timestamps.csv")
    assert list(stamps.columns) == ["t_s", "stamp_ns"] and len(stamps) == n
    video_t = np.array([s for s, _, _ in streams["/gelsight/right/image_raw"][1]])
    assert (stamps["stamp_ns"].to_numpy() == video_t).all()
    assert stamps["t_s"].iloc[0] == pytest.approx(0.005)  # from the earliest frame of all topics
    status, out, err = _run(capsys, "extract", trial_dir, "--json")
    assert status == 0, err
    fit = json.loads(out)
    assert fit["angular_frequency"] == pytest.approx(video_fit.angular_frequency, rel=1e-6)
    assert fit["decay_rate"] == pytest.approx(video_fit.decay_rate, rel=1e-6)


@pytest.mark.parametrize("ros1", [False, True], ids=["ros2", "ros1"])
def test_bag_encodings_compressed_images_and_time_source(tmp_path: Path, ros1: bool) -> None:
    pytest.importorskip("rosbags")
    import cv2

    from liquidtouch.io.rosbag import bag_image_topics, import_bag

    frames = [_dots(k) for k in range(4)]
    colour = [np.dstack([f, f // 2, 255 - f]) for f in frames]  # B, G, R planes differ
    stamps = [EPOCH_NS + k * 40_000_000 for k in range(4)]
    jpeg = [(s, s, f) for s, f in zip(stamps, frames, strict=True)]
    rgb = [(s, s, c[:, :, ::-1]) for s, c in zip(stamps, colour, strict=True)]
    unset = [(0, s + 7, f) for s, f in zip(stamps, frames, strict=True)]  # header stamps 0
    bag = write_bag(
        tmp_path / ("run.bag" if ros1 else "run"),
        {
            "/cam/left/image_raw/compressed": ("jpeg", jpeg),
            "/cam/right/image_raw": ("rgb8", rgb),
            "/cam/mid/image": ("png", unset),
        },
        ros1=ros1,
    )
    assert set(bag_image_topics(bag)) == {
        "/cam/left/image_raw/compressed", "/cam/right/image_raw", "/cam/mid/image",
    }  # fmt: skip
    out = tmp_path / "out"
    out.mkdir()
    topics = ["/cam/left/image_raw/compressed", "/cam/right/image_raw"]
    imported = import_bag(bag, out, topics=topics)
    assert [t.folder for t in imported] == ["left", "right"]
    assert imported[0].frames == 4 and imported[0].fps == pytest.approx(25.0)
    jpgs = sorted((out / "left").glob("*.jpg"))
    assert len(jpgs) == 4  # the JPEG bytes as recorded, not re-encoded
    right = cv2.imread(str(out / "right" / "000002.png"), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(right, colour[2])  # rgb8 stored as a BGR PNG
    # unset header stamps: refused with the hint, accepted with the bag's times
    with pytest.raises(DatasetError, match="`time_source` bag"):
        import_bag(bag, tmp_path / "mid1", topics=["/cam/mid/image"])
    mid = import_bag(bag, tmp_path / "mid2", topics=["/cam/mid/image"], time_source="bag")
    assert mid[0].folder == "mid" and mid[0].frames == 4
    text = (tmp_path / "mid2" / "mid" / "timestamps.csv").read_text().splitlines()
    assert text[1] == f"0.000000000,{stamps[0] + 7}"
    with pytest.raises(DatasetError, match="has no topic /nope"):
        import_bag(bag, tmp_path / "x", topics=["/nope"])


def test_bad_bags_are_refused(tmp_path: Path, capsys, monkeypatch) -> None:
    pytest.importorskip("rosbags")
    from liquidtouch.io.dataset_dir import init_dataset
    from liquidtouch.io.rosbag import import_bag

    stamps = [EPOCH_NS + k * 40_000_000 for k in range(3)]
    deep = [np.full((4, 5), 1000 * k, dtype=np.uint16) for k in range(3)]
    deep_frames = [(s, s, d) for s, d in zip(stamps, deep, strict=True)]
    bag = write_bag(tmp_path / "deep", {"/d/image_raw": ("mono16", deep_frames)})
    with pytest.raises(DatasetError, match="encoding 'mono16'"):
        import_bag(bag, tmp_path / "o1")
    backwards = [(s, k, _dots(k)) for k, s in enumerate(stamps[::-1])]
    bag = write_bag(tmp_path / "back", {"/b/image_raw": ("mono8", backwards)})
    with pytest.raises(DatasetError, match="must increase"):
        import_bag(bag, tmp_path / "o2")
    junk = tmp_path / "junk.bag"
    junk.write_bytes(b"#ROSBAG V2.0\n" + b"\0" * 64)
    with pytest.raises(DatasetError, match="cannot read bag"):
        import_bag(junk, tmp_path / "o3")
    # the command line: one error line, nothing left in the dataset
    root = init_dataset(tmp_path / "data")
    before = sorted(p.name for p in root.iterdir())
    status, _, err = _run(capsys, "dataset", "add", root, "--bag", bag, "-l", "liquid=water")
    assert status == 2 and err.startswith("error: ") and "must increase" in err
    assert sorted(p.name for p in root.iterdir()) == before
    # without rosbags: the install hint
    monkeypatch.setitem(sys.modules, "rosbags.highlevel", None)
    status, _, err = _run(capsys, "dataset", "add", root, "--bag", bag)
    assert status == 2 and "pip install 'liquidtouch[ros]'" in err
    assert sorted(p.name for p in root.iterdir()) == before


def test_topic_sensor_names() -> None:
    assert topic_sensor_names(["/gelsight/left/image_raw", "/gelsight/right/image_raw"]) == [
        "left",
        "right",
    ]
    assert topic_sensor_names(["/gelsight/image_raw/compressed"]) == ["gelsight"]
    assert topic_sensor_names(["/gelsight/left/image_raw"]) == ["left"]
    assert topic_sensor_names(["/a/x/image", "/b/x/image"]) == ["a", "b"]
    assert topic_sensor_names(["/x/a", "/x/a/image"]) == ["x_a", "x_a_image"]
    assert topic_sensor_names(["/a/image", "/b/image"]) == ["a", "b"]


def test_marker_trial_copies_cleanly(simulated, tmp_path: Path) -> None:
    """A tracks trial is self-contained: copied elsewhere it extracts the same."""
    _, directory, _ = simulated
    from liquidtouch.extraction.pipeline import extract_trial
    from liquidtouch.io.dataset_dir import init_dataset
    from liquidtouch.io.recordings import add_trial

    root = init_dataset(tmp_path / "data")
    added = add_trial(
        root, markers=_write_truth_csv(directory / "truth_tracks.npz", tmp_path, header=True)
    )
    copy = shutil.copytree(added.path, tmp_path / "copy")
    assert extract_trial(copy)["decay_rate"] == pytest.approx(
        extract_trial(added.path)["decay_rate"]
    )
