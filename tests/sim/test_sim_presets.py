"""Presets have the paper's sizes and ranges; datasets and the CLI write what they promise."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from liquidtouch._core.liquids import get_liquid
from liquidtouch.cli import main
from liquidtouch.errors import CatalogueError
from liquidtouch.io.dataset import read_trial_meta
from liquidtouch.sim.presets import TrialSpec, get_preset, preset_names, simulate_dataset
from liquidtouch.sim.trial import simulate_trial
from liquidtouch.sim.trial_io import FORCE_COLUMNS, write_trial


def _split(specs, split):
    return [s for s in specs if s.split == split]


def test_sugar_preset_sizes_and_ranges():
    specs = get_preset("sugar")
    train, test = _split(specs, "train"), _split(specs, "test")
    assert len(train) == 108 and len(test) == 288
    conc = lambda ss: sorted({s.kwargs["sugar_concentration"] for s in ss})  # noqa: E731
    assert conc(train) == pytest.approx(list(np.arange(0, 161, 20)))
    assert conc(test) == pytest.approx(list(np.arange(10, 151, 20)))
    heights = sorted({s.kwargs["height_mm"] for s in specs})
    assert len(heights) == 12 and heights[0] == 16.0 and heights[-1] == 40.0
    assert all(s.kwargs["liquid"] == "sugar-water" for s in specs)


def test_classification_other_liquids_and_force_torque_presets():
    cls = get_preset("classification")
    assert Counter(s.kwargs["liquid"] for s in _split(cls, "train")) == {
        "water": 8,
        "olive-oil": 8,
        "detergent": 8,
    }
    assert Counter(s.kwargs["liquid"] for s in _split(cls, "test")) == {
        "water": 70,
        "olive-oil": 70,
        "detergent": 70,
    }
    heights = [s.kwargs["height_mm"] for s in cls]
    assert min(heights) >= 20.0 and max(heights) <= 40.0  # 1/3 - 2/3 of the 60 mm height
    other = get_preset("other-liquids")
    assert len(other) == 108 and {s.split for s in other} == {"test"}
    assert set(Counter(s.kwargs["liquid"] for s in other).values()) == {36}
    ft = get_preset("force-torque")
    assert len(ft) == len(cls)
    assert {s.seed for s in ft}.isdisjoint({s.seed for s in cls})


@pytest.mark.parametrize(
    ("container", "n_train", "n_test", "low", "high"),
    [
        ("cylinder", 117, 104, 12.0, 35.0),
        ("cuboid", 108, 96, 15.0, 38.0),
        ("glass", 63, 56, 22.0, 39.0),
    ],
)
def test_container_presets(container, n_train, n_test, low, high):
    specs = [s for s in get_preset("containers") if s.kwargs["container"] == container]
    assert len(_split(specs, "train")) == n_train and len(_split(specs, "test")) == n_test
    heights = [s.kwargs["height_mm"] for s in specs]
    assert min(heights) == pytest.approx(low) and max(heights) == pytest.approx(high)


@pytest.mark.parametrize("name", preset_names())
def test_presets_are_unique_deterministic_and_quick_is_a_small_subset(name):
    full = get_preset(name)
    assert len({s.name for s in full}) == len(full)
    assert len({s.seed for s in full}) == len(full)
    quick = get_preset(name, quick=True)
    assert 15 <= len(quick) <= 90
    assert {s.name for s in quick} <= {s.name for s in full}
    assert [s.name for s in quick] == [s.name for s in get_preset(name, quick=True)]
    assert {s.split for s in quick} == {s.split for s in full}


def test_unknown_preset_lists_known_names():
    with pytest.raises(CatalogueError, match="known presets: classification"):
        get_preset("everything")


def test_write_trial_files_and_meta(tmp_path: Path):
    trial = simulate_trial("mirin", height_mm=22.0, seed=7)
    out = write_trial(trial, tmp_path / "t", video=False)
    meta = read_trial_meta(out)
    assert meta.sensors == [] and meta.fps == 30.0
    assert meta.liquid == "mirin" and meta.height_mm == 22.0
    assert meta.true_decay_rate == trial.true_decay_rate
    assert meta.log10_viscosity_cst == pytest.approx(np.log10(meta.viscosity_cst))
    force = np.loadtxt(out / "force.csv", delimiter=",", skiprows=1)
    header = (out / "force.csv").read_text().splitlines()[0].split(",")
    assert tuple(header) == FORCE_COLUMNS
    np.testing.assert_allclose(force[:, 1], trial.loads.shear_force_n[:, 0, 0], atol=1e-6)
    wrench = np.loadtxt(out / "wrench.csv", delimiter=",", skiprows=1)
    assert wrench.shape == (trial.t_s.size, 7)
    assert not list(out.glob(".*"))  # no temporary files left behind


def test_simulate_dataset_reports_a_bad_trial_and_keeps_the_rest(tmp_path: Path):
    specs = [
        TrialSpec("train/a", {"liquid": "water", "height_mm": 20.0}, "train", 1),
        TrialSpec("train/bad", {"liquid": "water", "height_mm": 99.0}, "train", 2),
        TrialSpec("test/b", {"liquid": "olive-oil", "height_mm": 30.0}, "test", 3),
    ]
    result = simulate_dataset(specs, tmp_path, jobs=2, video=False, progress=False)
    assert result.n_trials == 2
    assert [f[0] for f in result.failures] == ["train/bad"]
    assert "does not fit" in result.failures[0][1]
    manifest = (tmp_path / "manifest.csv").read_text().splitlines()
    assert manifest[0].startswith("trial,split,liquid")
    assert [row.split(",")[0] for row in manifest[1:]] == ["train/a", "test/b"]
    assert read_trial_meta(tmp_path / "test/b").liquid == "olive-oil"


def test_cli_simulate_trial_json_and_plot(tmp_path: Path, capsys):
    out = tmp_path / "trial"
    argv = ["simulate", "trial", "--liquid", "sugar-water", "--sugar-concentration", "160"]
    argv += ["--height-mm", "30", "--out", str(out), "--no-video", "--plot", "--json"]
    argv += ["--temperature-c", "20"]
    assert main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert {"force.csv", "wrench.csv", "meta.json", "loads.png"} <= set(summary["files"])
    meta = read_trial_meta(out)
    assert meta.sugar_concentration == 160.0  # the nominal label
    # the viscosity label is the true solution's (2 % weighing error) at 20 °C
    true_c = meta.model_extra["true_sugar_concentration"]
    assert true_c == pytest.approx(160.0, rel=0.08)
    expected = get_liquid("sugar-water", sugar_concentration=true_c).viscosity_cst
    assert summary["viscosity_cst"] == pytest.approx(expected)
    assert 45.0 <= summary["viscosity_cst"] <= 75.0


@pytest.mark.parametrize(
    "argv",
    [
        ["simulate", "trial", "--liquid", "honey", "--height-mm", "20"],
        ["simulate", "trial", "--liquid", "water", "--height-mm", "20", "--container", "jar"],
        ["simulate", "trial", "--liquid", "sugar-water", "--height-mm", "20"],
        ["simulate", "trial", "--liquid", "water", "--height-mm", "80"],
        ["simulate", "dataset", "--preset", "everything"],
        ["simulate", "dataset", "--preset", "sugar", "--jobs", "0"],
    ],
)
def test_cli_bad_input_exits_2_with_one_line(argv, tmp_path: Path, capsys):
    assert main([*argv, "--out", str(tmp_path / "x"), "--no-video"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ")


def test_cli_presets_and_quick_dataset(tmp_path: Path, capsys, monkeypatch):
    assert main(["simulate", "presets", "--json"]) == 0
    table = json.loads(capsys.readouterr().out)["presets"]
    assert table["sugar"]["train"] == 108 and table["sugar"]["test"] == 288
    # a two-trial "preset" through the CLI path: keep it fast
    import liquidtouch.sim.presets as presets

    small = get_preset("other-liquids", quick=True)[:2]
    monkeypatch.setattr(presets, "get_preset", lambda name, quick=False: small)
    argv = ["simulate", "dataset", "--preset", "other-liquids", "--out", str(tmp_path)]
    assert main([*argv, "--quick", "--no-video", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["n_trials"] == 2 and summary["failures"] == []
    assert (tmp_path / "manifest.csv").is_file()


def test_write_trial_with_video_lists_the_sensor_videos(tmp_path: Path):
    from liquidtouch.sim import gelsight

    assert hasattr(gelsight, "write_sensor_videos")
    trial = simulate_trial("water", height_mm=25.0, seed=3, duration_s=3.0)
    out = write_trial(trial, tmp_path / "v", video=True)
    meta = read_trial_meta(out)
    assert meta.sensors == ["left.mp4", "right.mp4"]
    assert 20.0 <= meta.fps <= 31.0
    for name in meta.sensors:
        assert (out / name).stat().st_size > 1000


def test_plot_trial_returns_a_figure_and_saves_by_suffix(tmp_path: Path):
    import matplotlib
    from matplotlib.figure import Figure

    from liquidtouch.sim.trial_io import plot_trial

    backend = matplotlib.get_backend()
    trial = simulate_trial("water", height_mm=25.0, seed=3, duration_s=3.0)
    fig = plot_trial(trial, tmp_path / "loads.pdf")
    assert isinstance(fig, Figure) and len(fig.axes) == 3
    assert (tmp_path / "loads.pdf").read_bytes().startswith(b"%PDF")
    assert [p.name for p in tmp_path.iterdir()] == ["loads.pdf"]  # no temporary file left
    assert matplotlib.get_backend() == backend  # the library never switches the backend

    host = Figure()
    axes = host.subplots(3, 1)
    assert plot_trial(trial, axes=axes) is host
    assert all(ax.lines for ax in axes)
    with pytest.raises(ValueError, match="3 panels"):
        plot_trial(trial, axes=axes[:2])


def test_trial_labels_are_the_dataset_columns():
    from liquidtouch.io.dataset import LABEL_COLUMNS, TRUTH_COLUMNS

    labels = simulate_trial("olive-oil", height_mm=28.0, seed=3, duration_s=3.0).labels()
    assert tuple(labels) == (*LABEL_COLUMNS, *TRUTH_COLUMNS)
