"""One consistent command line: shared options, the fit's start, formatting, provenance.

The commands of ``cli/fit.py``, ``cli/extract.py`` (``extract``, ``features``) and
``cli/models.py`` declare their common options once (``cli/options.py``) and print
numbers through one formatter (``cli/format.py``).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import typer.main

from liquidtouch._core.numbers import fixed, number, with_uncertainty
from liquidtouch.cli import app, main, options

MY_COMMANDS = ("fit", "extract", "features", "train", "classify", "predict", "transfer")
FIT_OPTIONS = ("--loss", "--model", "--band-low", "--band-high", "--noise", "--start")
SIGNAL_OPTIONS = ("--lowpass", "--markers", "--sensor")
TRIALS = [("a/water_h25", "water", 25.0, 1), ("b/olive_h30", "olive-oil", 30.0, 2)]


def _commands() -> dict:
    return typer.main.get_command(app).commands


def _all_commands(command=None, path: tuple[str, ...] = ()) -> dict[tuple[str, ...], object]:
    """Every command of the app by its path, e.g. ``("simulate", "trial")`` (groups walked)."""
    command = typer.main.get_command(app) if command is None else command
    subcommands = getattr(command, "commands", None)
    if subcommands is None:
        return {path: command}
    found: dict[tuple[str, ...], object] = {}
    for name, sub in subcommands.items():
        found.update(_all_commands(sub, (*path, name)))
    return found


def _params(command: str) -> dict[str, object]:
    """The command's options by their long flag."""
    return {
        next(o for o in p.opts if o.startswith("--")): p
        for p in _commands()[command].params
        if p.param_type_name == "option"
    }


def _choices(param) -> object:
    """The declared type of an option (typer's descriptor, or click's type)."""
    descriptor = getattr(param, "type_descriptor", None)
    return descriptor.annotation if descriptor is not None else param.type


def _run(capsys, *argv) -> tuple[int, str, str]:
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def _one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), lines
    return lines[0]


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two simulated trials (GelSight Mini videos, 9 s) with a split column."""
    from liquidtouch.io.dataset import write_manifest
    from liquidtouch.sim.trial import simulate_trial
    from liquidtouch.sim.trial_io import write_trial

    root = tmp_path_factory.mktemp("consistency")
    rows = []
    for (name, liquid, height_mm, seed), split in zip(TRIALS, ("train", "test"), strict=True):
        trial = simulate_trial(liquid, height_mm=height_mm, seed=seed, duration_s=9.0)
        write_trial(trial, root / name, sensor="mini")
        rows.append({"trial": name, "split": split, **trial.labels()})
    write_manifest(root, rows)
    return root


@pytest.fixture
def fresh(dataset: Path, tmp_path: Path) -> Path:
    copy = tmp_path / "data"
    shutil.copytree(dataset, copy, ignore=shutil.ignore_patterns(".cache", "features*.csv"))
    return copy


# -- 1: fit cuts the free decay as extract does ----------------------------------------------


def test_fit_of_extracted_whole_signal_equals_extract(dataset: Path, tmp_path: Path, capsys):
    trial = dataset / TRIALS[0][0]
    signal = tmp_path / "u.csv"
    status, out, _ = _run(capsys, "extract", trial, "--json", "--signal-out", signal)
    assert status == 0
    extracted = json.loads(out)
    t = pd.read_csv(signal)["t"]
    assert t.iloc[0] < extracted["t0"] - 0.5  # the CSV holds the record before the push too
    status, out, _ = _run(capsys, "fit", signal, "--json")
    assert status == 0
    fitted = json.loads(out)
    for key in ("decay_rate", "angular_frequency"):
        assert fitted[key] == pytest.approx(extracted[key], rel=1e-6)
    assert fitted["t0"] == pytest.approx(extracted["t0"], abs=1e-6)
    # an explicit start at the free decay's first sample is the same window
    start = f"{extracted['t0'] - 1e-6:.6f}"  # the CSV's times have 9 significant digits
    status, out, _ = _run(capsys, "fit", signal, "--json", "--start", start)
    assert status == 0
    assert json.loads(out)["decay_rate"] == pytest.approx(extracted["decay_rate"], rel=1e-6)
    # the same fit options on both commands give the same numbers
    for flag, value in (("--loss", "ls"), ("--model", "single-mode")):
        status, out, _ = _run(capsys, "extract", trial, "--json", flag, value)
        by_extract = json.loads(out)
        status2, out, _ = _run(capsys, "fit", signal, "--json", flag, value)
        assert status == status2 == 0 and by_extract[flag[2:]] == value
        assert json.loads(out)["decay_rate"] == pytest.approx(by_extract["decay_rate"], rel=1e-6)


@pytest.mark.parametrize(
    ("start", "message"),
    [
        ("abc", "neither 'auto' nor a time"),
        ("nan", "neither 'auto' nor a time"),
        ("inf", "neither 'auto' nor a time"),
        ("12", "leaves 0 s of the signal"),
        ("11.5", "the fit needs at least 2 s"),
    ],
)
def test_fit_start_is_validated(tmp_path: Path, capsys, start: str, message: str) -> None:
    from liquidtouch.fit.example import example_signal
    from liquidtouch.io.signal_csv import write_signal_csv

    path = tmp_path / "s.csv"
    t, u = example_signal(seed=1)
    write_signal_csv(path, t[t < 12], u[t < 12])
    status, _, err = _run(capsys, "fit", path, "--start", start)
    assert status == 2 and message in _one_error_line(err)


def test_fit_start_number_cuts_there(tmp_path: Path, capsys) -> None:
    from liquidtouch.fit.example import example_signal
    from liquidtouch.io.signal_csv import write_signal_csv

    path = tmp_path / "s.csv"
    write_signal_csv(path, *example_signal(seed=1))
    status, out, _ = _run(capsys, "fit", path, "--json", "--start", "2.5")
    doc = json.loads(out)
    assert status == 0 and 2.5 <= doc["t0"] < 2.6 and doc["duration_s"] <= 10.5
    status, out, _ = _run(capsys, "fit", path, "--json", "--start", "-5")  # before: all of it
    assert status == 0 and json.loads(out)["t0"] == 0.0


# -- 3: the same options everywhere ----------------------------------------------------------


def test_my_commands_exist_and_share_flags() -> None:
    commands = _commands()
    for name in MY_COMMANDS:
        assert name in commands, name
        assert "--json" in _params(name), name
    for name in ("features", "predict"):
        assert {"--jobs", "--dask", "--sensor"} <= set(_params(name)), name
    assert "--sensor" in _params("extract")


def test_every_out_and_jobs_has_its_short_flag() -> None:
    """Every command of the app (groups too): ``--out``/``-o``, one shared ``--jobs``/``-j``."""
    with_out, with_jobs = set(), {}
    for path, command in _all_commands().items():
        for param in command.params:
            if "--out" in param.opts:
                assert "-o" in param.opts, path
                with_out.add(path)
            if "--jobs" in param.opts:
                assert "-j" in param.opts, path
                with_jobs[path] = (tuple(param.opts), param.help)
    assert {("train",), ("predict",), ("simulate", "trial"), ("reproduce",)} <= with_out
    assert {("features",), ("predict",), ("simulate", "dataset"), ("demo",)} <= set(with_jobs)
    assert len(set(with_jobs.values())) == 1, with_jobs  # declared once (options.Jobs)


@pytest.mark.parametrize("command", ["extract", "features", "predict"])
def test_fit_and_signal_options_are_declared_once(command: str) -> None:
    fit, other = _params("fit"), _params(command)
    for flag in FIT_OPTIONS:
        a, b = fit[flag], other[flag]
        assert (a.opts, a.help, a.default, a.metavar) == (b.opts, b.help, b.default, b.metavar)
        assert _choices(a) == _choices(b)
    extract = _params("extract")
    for flag in SIGNAL_OPTIONS:
        a, b = extract[flag], other[flag]
        assert (a.opts, a.help, a.default) == (b.opts, b.help, b.default)


def test_choices_are_the_librarys_and_listed_in_help(capsys) -> None:
    from liquidtouch.batch.features import SOURCES
    from liquidtouch.extraction.fit_settings import FitSettings
    from liquidtouch.fit.choices import LOSSES, MODELS, NOISE_MODELS
    from liquidtouch.models.property_model import MODEL_KINDS
    from liquidtouch.signal.tactile import DEFAULT_N_MARKERS

    assert [c.value for c in options.LossChoice] == list(LOSSES)
    assert [c.value for c in options.FitModelChoice] == list(MODELS)
    assert [c.value for c in options.NoiseChoice] == list(NOISE_MODELS)
    assert [c.value for c in options.RegressorChoice] == list(MODEL_KINDS)
    assert [c.value for c in options.SourceChoice] == list(SOURCES)
    defaults = options.fit_settings(
        options.DEFAULT_LOSS,
        options.DEFAULT_FIT_MODEL,
        options.DEFAULT_BAND_LOW_HZ,
        options.DEFAULT_BAND_HIGH_HZ,
        options.DEFAULT_NOISE,
        None,
    )
    assert defaults == FitSettings()
    assert options.DEFAULT_MARKERS == DEFAULT_N_MARKERS  # the CLI's copy, kept light to import
    for command, listed in (
        ("fit", ("paper", "ls", "two-mode", "single-mode", "white", "correlated")),
        ("train", ("gpr", "quadratic", "physics-gpr")),
    ):
        status, out, _ = _run(capsys, command, "--help")
        assert status == 0
        for choice in listed:
            assert choice in out, (command, choice)
    status, _, err = _run(capsys, "extract", "trial", "--loss", "l1")
    assert status == 2 and "'l1' is not one of" in _one_error_line(err)


def test_help_keeps_units(capsys) -> None:
    status, out, _ = _run(capsys, "fit", "--help")
    assert status == 0 and "[Hz]" in out and "auto|SECONDS" in out
    status, out, _ = _run(capsys, "extract", "--help")
    assert status == 0 and "[Hz]" in out and ".csv" in out


# -- 4: numbers ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("value", "std", "text"),
    [
        (11.00003, 0.0051, "11.0000 ± 0.0051"),
        (0.17349, 0.00214, "0.1735 ± 0.0021"),
        (0.1628, 0.0996, "0.16 ± 0.10"),
        (14.998, 0.25, "15.00 ± 0.25"),
        (1234.5, 56.0, "1234 ± 56"),
        (1234.5, 560.0, "1230 ± 560"),
        (3.0e-7, 2.0e-8, "(3.00 ± 0.20)e-07"),
        (2.5, float("nan"), "2.500"),
        (2.5, None, "2.500"),
        (float("nan"), 0.1, "—"),
    ],
)
def test_value_rounded_to_its_uncertainty(value, std, text) -> None:
    assert with_uncertainty(value, std) == text


def test_plain_values() -> None:
    assert number(0.012345) == "0.01235"
    assert number(12345.6) == "12346"
    assert number(9.99996) == "10.00"
    assert number(0.0) == "0" and number(None) == "—"
    assert number(1.5e-5) == "1.500e-05"
    assert fixed(0.9990466904010268) == "0.9990"


def test_fit_table_has_units_and_rounded_values(tmp_path: Path, capsys) -> None:
    status, out, _ = _run(capsys, "fit", "--example", "--model", "two-mode")  # its model
    assert status == 0
    assert "[rad/s]" in out and "[1/s]" in out
    slow = next(line for line in out.splitlines() if "slow" in line)
    cells = [c.strip() for c in slow.split("│") if c.strip()]
    for cell in cells[1:3]:
        value, std = cell.split(" ± ")
        assert len(std.replace(".", "").lstrip("0")) == 2  # 2 significant digits
        assert len(value.partition(".")[2]) == len(std.partition(".")[2])  # same place
    assert "R² = 0.99" in out and "0.99" in out


def test_extract_prints_formatted_table(dataset: Path, capsys) -> None:
    status, out, _ = _run(capsys, "extract", dataset / TRIALS[0][0])
    assert status == 0
    assert "[rad/s]" in out and " ± " in out
    r2 = next(line for line in out.splitlines() if line.startswith("R² = "))
    assert len(r2.split()[2]) == len("0.9999")  # 4 decimals, not 0.9990466904010268


# -- 5: the extraction figure ------------------------------------------------------------------


def test_extraction_plot_draws_the_fit_only_over_its_window(dataset: Path) -> None:
    from liquidtouch.extraction.pipeline import extract
    from liquidtouch.extraction.plot import plot_extraction

    result = extract(dataset / TRIALS[0][0])
    fig = plot_extraction(result)
    ax = next(a for a in fig.axes if any(ln.get_label() == "fit" for ln in a.lines))
    curve = next(ln for ln in ax.lines if ln.get_label() == "fit")
    x = np.asarray(curve.get_xdata())
    start = result.fit.t0
    assert x.min() >= start - 1e-9 and result.signal.t[0] < start - 0.5
    span = [p for p in ax.patches if p.get_label() == "fitted window"]
    assert len(span) == 1
    x0, x1 = span[0].get_x(), span[0].get_x() + span[0].get_width()
    assert x0 == pytest.approx(start) and x1 == pytest.approx(start + result.fit.duration_s)


# -- 7: tracks as CSV ------------------------------------------------------------------------


def test_tracks_csv_long_format(dataset: Path, tmp_path: Path, capsys) -> None:
    from liquidtouch.tracking.tracks import load_tracks

    trial = dataset / TRIALS[0][0]
    csv, npz = tmp_path / "tracks.csv", tmp_path / "tracks.npz"
    assert main(["extract", str(trial), "--json", "--tracks-out", str(csv)]) == 0
    assert main(["extract", str(trial), "--json", "--tracks-out", str(npz)]) == 0
    capsys.readouterr()
    table = pd.read_csv(csv)
    assert list(table.columns) == ["t", "sensor", "marker", "x", "y", "valid"]
    tracks = load_tracks(npz)
    assert len(table) == sum(tr.valid.size for tr in tracks)
    for tr in tracks:
        rows = table[table["sensor"] == tr.sensor]
        x = rows["x"].to_numpy().reshape(tr.valid.shape)
        np.testing.assert_allclose(x, tr.positions[:, :, 0], atol=1e-6)
        np.testing.assert_array_equal(rows["valid"].to_numpy().reshape(tr.valid.shape), tr.valid)
        np.testing.assert_allclose(rows["t"].to_numpy()[:: tr.n_markers], tr.t, atol=1e-6)


def test_tracks_format_is_checked_before_any_video(tmp_path: Path, capsys) -> None:
    status, _, err = _run(
        capsys, "extract", tmp_path / "missing.mp4", "--tracks-out", tmp_path / "t.txt"
    )
    line = _one_error_line(err)
    assert status == 2 and ".npz or .csv" in line and "missing.mp4" not in line


# -- 3 and 6: features: options, cache key, JSON, provenance ---------------------------------


def test_features_json_settings_cache_and_provenance(fresh: Path, tmp_path: Path, capsys):
    import liquidtouch

    out = tmp_path / "f.csv"
    status, stdout, _ = _run(capsys, "features", fresh, "-o", out, "-j", "1", "--json")
    assert status == 0
    doc = json.loads(stdout)
    assert doc["out"] == str(out) and doc["n_trials"] == 2 and doc["n_extracted"] == 2
    assert doc["n_failed"] == 0 and doc["failed"] == [] and doc["n_computed"] == 2
    assert doc["settings"]["n_markers"] == 16 and doc["settings"]["fit"]["loss"] == "paper"
    table = pd.read_csv(out)
    assert (table["liquidtouch_version"] == liquidtouch.__version__).all()
    recorded = json.loads(table["extraction_settings"].iloc[0])
    assert recorded == doc["settings"]

    # the same settings: everything from the cache, the same numbers
    status, stdout, _ = _run(capsys, "features", fresh, "-o", out, "--json")
    again = json.loads(stdout)
    assert status == 0 and again["n_computed"] == 0 and again["n_cached"] == 2
    np.testing.assert_array_equal(pd.read_csv(out)["decay_rate"], table["decay_rate"])

    # another --markers (or fit option): recomputed, and recorded
    status, stdout, _ = _run(capsys, "features", fresh, "-o", out, "--json", "--markers", "8")
    changed = json.loads(stdout)
    assert status == 0 and changed["n_computed"] == 2 and changed["settings"]["n_markers"] == 8
    assert (pd.read_csv(out)["n_markers"] == 8).all()
    status, stdout, _ = _run(capsys, "features", fresh, "-o", out, "--json", "--loss", "ls")
    assert status == 0 and json.loads(stdout)["n_computed"] == 2
    status, stdout, _ = _run(capsys, "features", fresh, "-o", out, "--json", "--markers", "8")
    assert status == 0 and json.loads(stdout)["n_computed"] == 2  # one cache entry per trial

    # human output: counts; a bad sensor name is recorded per trial
    status, stdout, err = _run(capsys, "features", fresh, "--sensor", "middle")
    assert status == 2 and "0 of 2 trials extracted" in stdout  # nothing worked: not exit 0
    assert "failed: a/water_h25" in err and "no sensor 'middle'" in err
    assert err.count("no sensor 'middle'") == 2  # each trial's error once
    assert "error: no trial was extracted: all 2 failed" in err


def test_features_options_change_the_features(fresh: Path, capsys) -> None:
    from liquidtouch.batch.features import extract_features
    from liquidtouch.extraction.fit_settings import FitSettings

    base = extract_features(fresh, write=False, progress=False)
    left = extract_features(fresh, write=False, progress=False, sensors=["left"])
    single = extract_features(
        fresh, write=False, progress=False, fit_settings=FitSettings(model="single-mode")
    )
    assert (left["error"] == "").all() and not np.allclose(left["r2"], base["r2"])
    assert single["fast_decay_rate"].isna().all()
    assert json.loads(left["extraction_settings"][0])["sensors"] == ["left"]


# -- 3: predict --json ------------------------------------------------------------------------


def test_predict_json(tmp_path: Path, capsys) -> None:
    from liquidtouch.testing.synthetic_tables import (
        PAPER_CONCENTRATIONS,
        PAPER_HEIGHTS_MM,
        sugar_table,
    )

    train = tmp_path / "train.csv"
    test = tmp_path / "test.csv"
    sugar_table(PAPER_HEIGHTS_MM[::2], PAPER_CONCENTRATIONS[::3], seed=3).to_csv(train, index=False)
    rows = sugar_table(PAPER_HEIGHTS_MM[1::4], PAPER_CONCENTRATIONS[::6], seed=4)
    rows["error"] = ""
    rows.loc[1, ["decay_rate", "error"]] = [np.nan, "video unreadable"]
    rows.to_csv(test, index=False)
    model = tmp_path / "m.json"
    assert main(["train", str(train), "-t", "height_mm", "-m", "quadratic", "-o", str(model)]) == 0
    capsys.readouterr()
    out = tmp_path / "p.csv"
    status, stdout, err = _run(capsys, "predict", model, test, "-o", out, "--json")
    doc = json.loads(stdout)
    assert status == 0 and doc["out"] == str(out) and out.is_file()
    assert doc["n_rows"] == len(rows) and doc["n_failed"] == 1 and doc["failed_rows"] == [2]
    assert doc["n_predicted"] == len(rows) - 1 and doc["targets"] == ["height_mm"]
    assert "video unreadable" in err
    status, stdout, _ = _run(capsys, "predict", model, test, "--json")
    doc = json.loads(stdout)
    assert status == 0 and doc["out"] is None and len(doc["rows"]) == len(rows)
    assert doc["rows"][1]["predicted_height_mm"] is None
    assert doc["rows"][0]["predicted_height_mm"] == pytest.approx(
        pd.read_csv(out)["predicted_height_mm"][0], rel=1e-9
    )


def test_predict_extracts_a_dataset_with_the_features_options(fresh: Path, tmp_path, capsys):
    """``predict DATASET`` takes ``-j``, ``--dask`` and the extraction and fit options."""
    from liquidtouch.testing.synthetic_tables import (
        PAPER_CONCENTRATIONS,
        PAPER_HEIGHTS_MM,
        sugar_table,
    )

    train = tmp_path / "train.csv"
    sugar_table(PAPER_HEIGHTS_MM[::2], PAPER_CONCENTRATIONS[::3], seed=3).to_csv(train, index=False)
    model = tmp_path / "m.json"
    assert main(["train", str(train), "-t", "height_mm", "-m", "quadratic", "-o", str(model)]) == 0
    capsys.readouterr()
    argv = ["predict", model, fresh, "-j", "1", "--markers", "8", "--model", "single-mode"]
    status, stdout, _ = _run(capsys, *argv, "--json")
    doc = json.loads(stdout)
    assert status == 0 and doc["n_rows"] == 2 and doc["n_predicted"] == 2
    assert all(row["n_markers"] == 8 and row["fast_decay_rate"] is None for row in doc["rows"])
    assert not (fresh / "features.csv").exists()
    status, _, err = _run(capsys, "predict", model, fresh, "--markers", "0")
    assert status == 2 and "markers" in _one_error_line(err)
