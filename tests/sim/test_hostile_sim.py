"""Hostile inputs to the simulator and its commands: one ``error:`` line and exit 2 (Ctrl-C:
``error: interrupted`` and 130), never a traceback, never a corrupted or half-written trial.

Organised by what is attacked: an existing trial, the arguments, output paths, Ctrl-C.
"""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from liquidtouch.cli import main
from liquidtouch.errors import CatalogueError, LiquidTouchError, OutputError
from liquidtouch.sim.presets import TrialSpec, simulate_dataset
from liquidtouch.sim.trial import MAX_DURATION_S, MAX_SAMPLE_RATE_HZ, simulate_trial
from liquidtouch.sim.trial_io import write_trial

WATER = ("simulate", "trial", "--liquid", "water", "--height-mm", "30", "--no-video")
OLIVE = ("simulate", "trial", "--liquid", "olive-oil", "--height-mm", "25")


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str]:
    status = main(list(argv))
    return status, capsys.readouterr().err


def _one_error_line(err: str) -> bool:
    lines = err.splitlines()
    return len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in err


def _snapshot(root: Path) -> dict[str, bytes]:
    """Every file under ``root`` (hidden ones too) with its bytes."""
    return {
        str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()
    }


@pytest.fixture
def water_trial(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> Path:
    """A complete simulated water trial (loads only: fast) at ``tmp_path/trial``."""
    trial = tmp_path / "trial"
    assert main([*WATER, "--out", str(trial)]) == 0
    capsys.readouterr()
    return trial


# -- an existing trial is never corrupted --------------------------------------------------


def test_bad_sensor_leaves_an_existing_trial_byte_identical(
    water_trial: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    before = _snapshot(water_trial.parent)
    status, err = _run(capsys, *OLIVE, "--sensor", "bogus", "--out", str(water_trial))
    assert status == 2 and _one_error_line(err) and "unknown sensor 'bogus'" in err
    assert _snapshot(water_trial.parent) == before


@pytest.mark.parametrize(
    "extra",
    [
        ("--container", "bucket"),
        ("--seed", "-1"),
        ("--temperature-c", "nan"),
        ("--sugar-concentration", "20"),  # not for olive oil
    ],
)
def test_any_bad_argument_leaves_an_existing_trial_byte_identical(
    water_trial: Path, capsys: pytest.CaptureFixture[str], extra: tuple[str, ...]
) -> None:
    before = _snapshot(water_trial.parent)
    status, err = _run(capsys, *OLIVE, "--no-video", *extra, "--out", str(water_trial))
    assert status == 2 and _one_error_line(err)
    assert _snapshot(water_trial.parent) == before


@pytest.mark.parametrize(
    ("exc", "status", "message"),
    [
        (OSError(28, "No space left on device"), 2, "No space left"),
        (KeyboardInterrupt(), 130, "error: interrupted"),
    ],
)
def test_a_failure_while_writing_the_videos_leaves_the_old_trial_and_no_temp_dir(
    water_trial: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    exc: BaseException,
    status: int,
    message: str,
) -> None:
    import liquidtouch.sim.trial_io as trial_io

    def half_written_then_fail(loads, out_dir, **kwargs):
        (Path(out_dir) / "left.mp4").write_bytes(b"half a video")
        raise exc

    monkeypatch.setattr(trial_io, "write_sensor_videos", half_written_then_fail)
    before = _snapshot(water_trial.parent)
    got, err = _run(capsys, *OLIVE, "--out", str(water_trial))
    assert got == status and _one_error_line(err) and message in err
    assert _snapshot(water_trial.parent) == before  # no temporary directory either


def test_an_exception_in_write_trial_leaves_a_new_target_absent(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import liquidtouch.sim.trial_io as trial_io

    def fail(*args, **kwargs):
        raise RuntimeError("renderer crashed")

    monkeypatch.setattr(trial_io, "write_sensor_videos", fail)
    trial = simulate_trial("water", height_mm=30.0, seed=1, duration_s=3.0)
    with pytest.raises(RuntimeError, match="renderer crashed"):
        write_trial(trial, tmp_path / "new" / "trial")
    assert [p.name for p in (tmp_path / "new").iterdir()] == []


def test_resimulating_replaces_the_whole_trial(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    trial = tmp_path / "trial"
    write_trial(simulate_trial("water", height_mm=30.0, seed=1, duration_s=3.0), trial)
    assert (trial / "left.mp4").is_file()
    assert main([*OLIVE, "--no-video", "--out", str(trial)]) == 0
    capsys.readouterr()
    names = sorted(p.name for p in tmp_path.rglob("*"))
    assert names == ["force.csv", "meta.json", "trial", "wrench.csv"]  # no stale videos
    assert '"olive-oil"' in (trial / "meta.json").read_text()


def test_a_directory_with_other_files_is_never_replaced(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    home = tmp_path / "home"
    home.mkdir()
    (home / "thesis.tex").write_text("years of work")
    status, err = _run(capsys, *WATER, "--out", str(home))
    assert status == 2 and _one_error_line(err) and "thesis.tex" in err
    assert _snapshot(tmp_path) == {"home/thesis.tex": b"years of work"}


def test_a_failing_dataset_trial_keeps_its_old_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import liquidtouch.sim.trial_io as trial_io

    specs = [
        TrialSpec("train/a", {"liquid": "water", "height_mm": 20.0}, "train", 1),
        TrialSpec("train/b", {"liquid": "mirin", "height_mm": 25.0}, "train", 2),
    ]
    simulate_dataset(specs, tmp_path, video=False, progress=False)
    before = _snapshot(tmp_path)
    real = trial_io._write_csv

    def fail_on_b(path, header, table):
        real(path, header, table)
        if "/.b." in str(path):  # the temporary directory of train/b
            raise OSError(5, "Input/output error")

    monkeypatch.setattr(trial_io, "_write_csv", fail_on_b)
    result = simulate_dataset(specs, tmp_path, video=False, progress=False)
    assert [name for name, _ in result.failures] == ["train/b"]
    after = _snapshot(tmp_path)
    assert after["train/b/meta.json"] == before["train/b/meta.json"]
    assert not [name for name in after if "/." in name or name.startswith(".")]


def test_dataset_arguments_are_checked_before_anything_is_written(tmp_path: Path) -> None:
    specs = [TrialSpec("train/a", {"liquid": "water", "height_mm": 20.0}, "train", 1)]
    with pytest.raises(CatalogueError, match="unknown sensor"):
        simulate_dataset(specs, tmp_path / "ds", video=False, sensor="bogus")
    with pytest.raises(LiquidTouchError, match="jobs"):
        simulate_dataset(specs, tmp_path / "ds", jobs=0, video=False)
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(OutputError, match="not a directory"):
        simulate_dataset(specs, blocker, video=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


# -- hostile arguments ---------------------------------------------------------------------


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (("--seed", "-1"), "seed -1"),
        (("--seed", str(2**64)), "out of range"),
        (("--seed", "1.5"), "--seed"),
        (("--seed", ""), "--seed"),
        (("--height-mm", "-5"), "does not fit"),
        (("--height-mm", "0"), "does not fit"),
        (("--height-mm", "0.01"), "does not fit"),
        (("--height-mm", "59.99"), "does not fit"),
        (("--height-mm", "nan"), "does not fit"),
        (("--height-mm", "inf"), "does not fit"),
        (("--height-mm", "1e6"), "does not fit"),
        (("--height-mm", "1e308"), "does not fit"),
        (("--height-mm", "abc"), "--height-mm"),
        (("--liquid", ""), "unknown liquid"),
        (("--liquid", "WATER"), "unknown liquid"),
        (("--container", ""), "unknown container"),
        (("--sensor", ""), "unknown sensor"),
        (("--temperature-c", "-300"), "temperature"),
        (("--temperature-c", "inf"), "temperature"),
        (("--liquid", "sugar-water"), "needs a sugar concentration"),
        (("--liquid", "sugar-water", "--sugar-concentration", "nan"), "sugar concentration"),
        (("--liquid", "sugar-water", "--sugar-concentration", "1e300"), "sugar concentration"),
        (("--liquid", "sugar-water", "--sugar-concentration", "-1"), "sugar concentration"),
        (("--sugar-concentration", "10"), "only applies to sugar-water"),
    ],
)
def test_simulate_trial_hostile_arguments(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: tuple[str, ...], message: str
) -> None:
    out = tmp_path / "trial"
    status, err = _run(capsys, *WATER, "--out", str(out), *extra)
    assert status == 2 and _one_error_line(err) and message in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (("--preset", ""), "unknown preset"),
        (("--preset", "bogus"), "unknown preset"),
        (("--preset", "sugar", "--jobs", "0"), "--jobs"),
        (("--preset", "sugar", "--jobs", "-3"), "--jobs"),
        (("--preset", "sugar", "--jobs", "1.5"), "--jobs"),
    ],
)
def test_simulate_dataset_hostile_arguments(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: tuple[str, ...], message: str
) -> None:
    status, err = _run(capsys, "simulate", "dataset", *argv, "--out", str(tmp_path / "ds"))
    assert status == 2 and _one_error_line(err) and message in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "kwargs",
    [
        {"duration_s": 1e9},
        {"duration_s": MAX_DURATION_S + 1},
        {"duration_s": math.nan},
        {"duration_s": -3.0},
        {"sample_rate_hz": 1e9},
        {"sample_rate_hz": MAX_SAMPLE_RATE_HZ * 2},
        {"sample_rate_hz": math.inf},
        {"seed": -1},
        {"seed": 1.5},
        {"seed": True},
        {"seed": 2**63},
    ],
)
def test_simulate_trial_limits_are_checked_before_any_work(kwargs: dict[str, object]) -> None:
    start = time.perf_counter()
    with pytest.raises(LiquidTouchError):
        simulate_trial("water", height_mm=30.0, **kwargs)
    assert time.perf_counter() - start < 1.0  # refused, not attempted


def test_the_longest_trial_allowed_is_fine() -> None:
    trial = simulate_trial("water", height_mm=30.0, duration_s=MAX_DURATION_S, sample_rate_hz=60)
    assert trial.loads.duration_s == pytest.approx(MAX_DURATION_S)


# -- output paths --------------------------------------------------------------------------


@pytest.mark.parametrize(
    "out",
    ["", "/dev/null", "FILE", "FILE/sub", ".", "/"],
)
def test_simulate_out_that_cannot_be_a_trial_directory(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, out: str
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "FILE").write_text("x")
    status, err = _run(capsys, *WATER, "--out", out)
    assert status == 2 and _one_error_line(err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["FILE"]


def test_simulate_out_with_a_trailing_slash_is_a_directory(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    status, _ = _run(capsys, *WATER, "--out", f"{tmp_path}/trial/")
    assert status == 0 and (tmp_path / "trial" / "meta.json").is_file()


@pytest.mark.parametrize(
    "argv",
    [
        ("fit", "--example", "--plot", "{d}/fig.png/"),
        ("fit", "--example", "--plot", "{d}/existing"),
        ("fit", "--example", "--plot", ""),
        ("extract", "{d}/nothing.mp4", "--signal-out", "{d}/u.csv/"),
        ("extract", "{d}/nothing.mp4", "--tracks-out", "{d}/tracks.npz/"),
        ("extract", "{d}/nothing.mp4", "--plot", "{d}/existing"),
        ("train", "{d}/f.csv", "--target", "height_mm", "--out", "{d}/model.json/"),
        ("classify", "{d}/f.csv", "-o", "{d}/model.json/"),
        ("predict", "{d}/m.json", "{d}/f.csv", "--out", "{d}/p.csv/"),
        ("transfer", "{d}/m.json", "{d}/f.csv", "--out", "{d}/existing"),
        ("features", "{d}", "--out", "{d}/features.csv/"),
    ],
)
def test_file_outputs_spelled_as_directories_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: tuple[str, ...]
) -> None:
    (tmp_path / "existing").mkdir()
    status, err = _run(capsys, *(a.replace("{d}", str(tmp_path)) for a in argv))
    assert status == 2 and _one_error_line(err)
    assert "names a directory" in err or "is a directory" in err or "empty path" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["existing"]


# -- Ctrl-C --------------------------------------------------------------------------------

_RUN_CLI = "import sys; from liquidtouch.cli import run; run()"


def _interrupt(argv: list[str], ready, cwd: Path, *, settle_s: float = 1.0):
    """Run the command line, send SIGINT to its process group (as a terminal does) once
    ``ready()`` holds, and return (exit status, stderr)."""
    proc = subprocess.Popen(
        [sys.executable, "-c", _RUN_CLI, *argv],
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        deadline = time.monotonic() + 120
        while not ready() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert proc.poll() is None, f"finished before the interrupt: {proc.communicate()}"
        time.sleep(settle_s)
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
    return proc.returncode, err


def _temp_dirs(root: Path) -> list[Path]:
    return [p for p in root.rglob(".*") if p.is_dir()]


def test_ctrl_c_during_simulate_trial(tmp_path: Path) -> None:
    out = tmp_path / "trial"
    status, err = _interrupt(
        ["simulate", "trial", "--liquid", "water", "--height-mm", "30", "--out", str(out)],
        ready=lambda: bool(_temp_dirs(tmp_path)),
        cwd=tmp_path,
    )
    assert (status, err) == (130, "error: interrupted\n")
    assert list(tmp_path.iterdir()) == []  # no trial, no temporary directory


def test_ctrl_c_while_replacing_a_trial_leaves_it_byte_identical(
    water_trial: Path, tmp_path: Path
) -> None:
    before = _snapshot(tmp_path)
    status, err = _interrupt(
        [*OLIVE, "--out", str(water_trial)],
        ready=lambda: bool(_temp_dirs(tmp_path)),
        cwd=tmp_path,
    )
    assert (status, err) == (130, "error: interrupted\n")
    assert _snapshot(tmp_path) == before


def test_ctrl_c_during_simulate_dataset_with_a_process_pool(tmp_path: Path) -> None:
    root = tmp_path / "ds"
    status, err = _interrupt(
        ["simulate", "dataset", "--preset", "sugar", "--quick", "--jobs", "2", "--out", str(root)],
        ready=lambda: len(_temp_dirs(tmp_path)) >= 1,
        cwd=tmp_path,
        settle_s=1.5,
    )
    assert (status, err) == (130, "error: interrupted\n")  # no worker tracebacks
    assert _temp_dirs(tmp_path) == [] and not (root / "manifest.csv").exists()
    for trial in root.glob("*/*"):  # any trial that finished is complete
        assert (trial / "meta.json").is_file()
