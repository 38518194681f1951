"""The package skeleton: version, error handling of the CLI, atomic writes, trial metadata."""

from __future__ import annotations

import importlib
import json
import pkgutil

import pytest

import liquidtouch
from liquidtouch._core import atomic
from liquidtouch.cli import main
from liquidtouch.errors import DatasetError
from liquidtouch.io.dataset import TrialMeta, read_trial_meta, write_trial_meta


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"liquidtouch {liquidtouch.__version__}"


def test_unknown_command_is_a_one_line_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["no-such-command"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ")


def test_atomic_write_leaves_no_temp_on_failure(tmp_path) -> None:
    target = tmp_path / "out.json"
    atomic.write_json(target, {"a": 1})
    with pytest.raises(RuntimeError), atomic.atomic_path(target) as tmp:
        tmp.write_text("half")
        raise RuntimeError("crash")
    assert json.loads(target.read_text()) == {"a": 1}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.json"]


def test_trial_meta_round_trip_and_errors(tmp_path) -> None:
    meta = TrialMeta(fps=30.0, sensors=["left.mp4"], liquid="water", height_mm=20.0)
    write_trial_meta(tmp_path, meta)
    again = read_trial_meta(tmp_path)
    assert again.labels()["height_mm"] == 20.0 and again.sensors == ["left.mp4"]
    (tmp_path / "meta.json").write_text('{"fps": "fast"}')
    with pytest.raises(DatasetError, match="fps"):
        read_trial_meta(tmp_path)
    (tmp_path / "meta.json").write_text('{"fps": 30, "sensors": ["../x.mp4"]}')
    with pytest.raises(DatasetError, match="inside"):
        read_trial_meta(tmp_path)
    with pytest.raises(DatasetError, match="missing"):
        read_trial_meta(tmp_path / "nope")


def test_manifest_round_trip_and_validation(tmp_path) -> None:
    from liquidtouch.io.dataset import read_manifest, write_manifest

    rows = [
        {"trial": "train/t000", "liquid": "water", "height_mm": 16.0, "split": "train"},
        {"trial": "test/t001", "liquid": "olive-oil", "height_mm": 22.5, "split": "test"},
    ]
    write_manifest(tmp_path, rows)
    table = read_manifest(tmp_path)
    assert list(table["trial"]) == ["train/t000", "test/t001"]
    assert table["height_mm"].tolist() == [16.0, 22.5]
    with pytest.raises(DatasetError, match="inside"):
        write_manifest(tmp_path, [{"trial": "../escape"}])
    (tmp_path / "manifest.csv").write_text("trial,height_mm\na,16\nb,tall\n")
    with pytest.raises(DatasetError, match="row 3"):
        read_manifest(tmp_path)
    (tmp_path / "manifest.csv").write_text("trial,height_mm\na,16\na,17\n")
    with pytest.raises(DatasetError, match="twice"):
        read_manifest(tmp_path)
    (tmp_path / "manifest.csv").write_text("name,height_mm\na,16\n")
    with pytest.raises(DatasetError, match="no 'trial' column"):
        read_manifest(tmp_path)


def test_every_public_name_resolves() -> None:
    for name in liquidtouch.__all__:
        assert getattr(liquidtouch, name) is not None, name


PUBLIC_API = {
    "__version__",
    *("LiquidTouchError", "SignalError", "NoOscillationError"),
    *("fit_oscillation", "OscillationFit", "example_signal", "plot_fit"),
    *("read_signal_csv", "write_signal_csv", "iter_frames", "read_frames"),
    *("MarkerTracks", "detect_markers", "track_markers", "TactileSignal", "tactile_signal"),
    *("extract", "extract_signal", "Extraction", "free_decay"),
    *("GPRegressor", "QuadraticRegressor", "PhysicsGPRegressor", "LiquidClassifier"),
    *("PropertyModel", "train_regression", "train_classifier", "fit_transfer"),
    *("save_model", "load_model", "TrialMeta", "read_trial_meta", "read_manifest"),
    *("extract_features", "simulate_trial", "write_trial", "simulate_dataset"),
    *("write_sensor_videos", "FingerLoads", "reproduce", "plot_extraction"),
    "combine_ring_downs",
}


def test_public_api_is_pinned() -> None:
    """The restructure moved modules; every public name of ``lt`` must stay as it was."""
    assert set(liquidtouch.__all__) == PUBLIC_API
    importlib.import_module("liquidtouch.extraction.pipeline")  # a module once shadowed lt.extract

    assert callable(liquidtouch.extract) and liquidtouch.extract.__name__ == "extract"
    assert liquidtouch.fit_oscillation.__module__ == "liquidtouch.fit.oscillation"


def test_each_public_name_is_its_stages_own() -> None:
    """``lt.X`` is the object the stage that documents it exports, listed in its ``__all__``."""
    for name in liquidtouch.__all__:
        if name == "__version__":
            continue
        stage = importlib.import_module(f"liquidtouch.{liquidtouch._EXPORTS[name]}")
        assert getattr(liquidtouch, name) is getattr(stage, name), name
        assert name in stage.__all__, f"{name} not in {stage.__name__}.__all__"
    assert liquidtouch.plot_extraction.__module__ == "liquidtouch.extraction.plot"


def _is_private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def test_no_private_name_in_any_all() -> None:
    """Walk every liquidtouch module: each imports, and no ``__all__`` lists a ``_name``."""
    names = ["liquidtouch"] + [
        m.name for m in pkgutil.walk_packages(liquidtouch.__path__, "liquidtouch.")
    ]
    private = []
    for module_name in names:
        module = importlib.import_module(module_name)
        exported = getattr(module, "__all__", [])
        private += [f"{module_name}.{n}" for n in exported if _is_private(n)]
        missing = [n for n in exported if not hasattr(module, n)]
        assert missing == [], f"{module_name}.__all__ names what it lacks: {missing}"
    assert len(names) > 100 and private == []
