"""The simulated bench's nuisances (``sim.realism``): clean stays bit-identical, lab is recorded.

The clean digests were recorded with the simulator on ``main`` before ``Realism``
existed (same trials, GelSight Mini, 4 s): ``--realism clean`` must reproduce them.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import av
import numpy as np
import pytest
from helpers import SHARED

from liquidtouch.errors import LiquidTouchError
from liquidtouch.sim.realism import NUISANCES, Realism, get_realism
from liquidtouch.sim.render import make_background, render_frames
from liquidtouch.sim.sensors import get_sensor_profile
from liquidtouch.sim.trial import simulate_trial
from liquidtouch.sim.trial_io import write_trial

REAL_VIDEO = SHARED / "data" / "real"
REAL_VIDEO = REAL_VIDEO / "gelsight_mini_press.avi"

# digests of the simulator before Realism (main at af48236), see _digest
MAIN_DIGESTS = {
    "water": {
        "force.csv": "f6bb610c887c9185",
        "wrench.csv": "9d392b0936214ec8",
        "truth_tracks": "d6100de03b763271",
        "left.mp4": "597b01fd8fc720e3",
        "right.mp4": "fa72c4b9b8ada215",
        "meta": "f0e7bf538cc15978",
    },
    "sugar-water": {
        "force.csv": "1cefc8968f611368",
        "wrench.csv": "a6e370222d7dc572",
        "truth_tracks": "1d625a632070998c",
        "left.mp4": "721a54fb20f14219",
        "right.mp4": "4db613111bf4b20c",
        "meta": "ffe82a113092af4e",
    },
}
TRIALS = {"water": (25.0, 3, {}), "sugar-water": (30.0, 11, {"sugar_concentration": 80.0})}


def _digest(d: Path) -> dict[str, str]:
    """Short hashes of a trial's tables, truth tracks, decoded frames (+PTS) and meta."""
    out = {
        n: hashlib.sha256((d / n).read_bytes()).hexdigest()[:16]
        for n in ("force.csv", "wrench.csv")
    }
    with np.load(d / "truth_tracks.npz", allow_pickle=False) as z:
        h = hashlib.sha256()
        for k in sorted(z.files):
            h.update(k.encode())
            h.update(np.ascontiguousarray(z[k]).tobytes())
        out["truth_tracks"] = h.hexdigest()[:16]
    for name in ("left.mp4", "right.mp4"):
        h = hashlib.sha256()
        with av.open(str(d / name)) as c:
            for f in c.decode(video=0):
                h.update(f.to_ndarray(format="rgb24").tobytes())
                h.update(str(f.pts).encode())
        out[name] = h.hexdigest()[:16]
    meta = json.loads((d / "meta.json").read_text())
    meta.pop("realism", None)
    out["meta"] = hashlib.sha256(json.dumps(meta, sort_keys=True).encode()).hexdigest()[:16]
    return out


def _trial(liquid: str, realism: object = None, duration_s: float = 4.0):
    height, seed, extra = TRIALS[liquid]
    return simulate_trial(
        liquid, height_mm=height, seed=seed, duration_s=duration_s, realism=realism, **extra
    )


@pytest.mark.parametrize("liquid", list(TRIALS))
def test_clean_is_bit_identical_to_the_simulator_before_realism(tmp_path, liquid):
    trial = _trial(liquid, "clean")
    directory = write_trial(trial, tmp_path / "t", sensor="mini")
    assert _digest(directory) == MAIN_DIGESTS[liquid]
    meta = json.loads((directory / "meta.json").read_text())
    assert meta["realism"]["world"] == "clean"
    assert meta["realism"]["drawn"] == {}
    assert set(meta["realism"]["parameters"]) >= {f for fs in NUISANCES.values() for f in fs}


def test_lab_trial_records_its_world_and_differs(tmp_path):
    clean, lab = _trial("water"), _trial("water", "lab")
    assert not np.array_equal(clean.loads.shear_force_n, lab.loads.shear_force_n)
    directory = write_trial(lab, tmp_path / "t", sensor="mini")
    meta = json.loads((directory / "meta.json").read_text())
    record = meta["realism"]
    assert record["world"] == "lab"
    assert record["parameters"]["frame_rate_loss"] == pytest.approx(0.4)
    assert record["parameters"]["pixel_noise_rgb"] == [1.32, 1.06, 1.69]
    assert {"liquid_temperature_c", "fill_error_mm", "camera"} <= set(record["drawn"])
    assert 15.0 * 0.98 <= record["drawn"]["camera"]["fps"] <= 25.0
    with np.load(directory / "truth_tracks.npz") as z:
        assert "exposure_times_s" in z.files
        assert np.all(np.diff(z["timestamps_s"]) > 0)
    # the label is the viscosity measured at the recorded temperature, not the trial's
    assert lab.temperature_c == pytest.approx(clean.temperature_c)
    assert lab.viscosity_cst == pytest.approx(clean.viscosity_cst)


@pytest.mark.parametrize(
    ("name", "same_loads"),
    [("pixel_noise", True), ("frame_rate", True), ("temperature", False), ("finger_slip", False)],
)
def test_one_nuisance_changes_only_its_own_part(name, same_loads):
    clean = _trial("water", duration_s=13.0)
    factor = 20.0 if name == "finger_slip" else 1.0  # ~0.5 slips a trial: make sure of one
    one = _trial("water", Realism.only(name, factor), duration_s=13.0)
    assert one.realism.world.startswith(f"only:{name}")
    assert np.array_equal(clean.wrench, one.wrench) or name == "temperature"
    assert np.array_equal(clean.loads.shear_force_n, one.loads.shear_force_n) == same_loads


def test_realism_validation_and_names():
    assert get_realism(None) == Realism.clean() and get_realism("lab") == Realism.lab()
    assert Realism.clean().is_clean and not Realism.lab().is_clean
    doubled = Realism.lab().scaled("marker_wear", 2.0)
    assert doubled.marker_missing_fraction == pytest.approx(0.06)
    assert Realism.only("gel_creep", 2).gel_creep_fraction == pytest.approx(0.2)
    assert not Realism.only("gel_creep").active("temperature")
    with pytest.raises(LiquidTouchError, match="unknown realism"):
        get_realism("moon")
    with pytest.raises(LiquidTouchError, match="unknown nuisance"):
        Realism.only("gremlins")
    with pytest.raises(LiquidTouchError, match="negative"):
        Realism(fill_error_mm=-1.0)
    with pytest.raises(LiquidTouchError, match="leaves no frames"):
        Realism(frame_rate_loss=1.0)


def _noise_stats(frames: np.ndarray) -> tuple[np.ndarray, float]:
    """Per-channel temporal std and the mean 1-px neighbour correlation of still frames."""
    resid = frames - frames.mean(axis=0)
    std = np.sqrt((resid**2).sum(axis=0).mean(axis=(0, 1)) / (len(frames) - 1))
    a, b = resid[:, :, :-1], resid[:, :, 1:]
    corr = float(np.mean([(a[..., c] * b[..., c]).mean() / resid[..., c].var() for c in range(3)]))
    return std, corr


@pytest.mark.skipif(not REAL_VIDEO.is_file(), reason="../shared real recording absent")
def test_lab_pixel_noise_matches_the_real_gelsight_mini():
    frames = []
    with av.open(str(REAL_VIDEO)) as c:
        for i, f in enumerate(c.decode(video=0)):
            if i in (0, 12, 24, 36, 48):  # key frames while the gel is still
                frames.append(f.to_ndarray(format="rgb24").astype(float))
    real_std, real_corr = _noise_stats(np.array(frames))
    profile = get_sensor_profile("mini")
    rng = np.random.default_rng(0)
    lab = Realism.lab()
    still = np.zeros((8, 0, 2))
    sim = render_frames(
        still,
        profile,
        rng,
        background=make_background(profile, rng),
        flicker=False,
        noise_rgb=lab.pixel_noise_rgb,
        noise_corr_px=lab.pixel_noise_corr_px,
    ).astype(float)
    sim_std, sim_corr = _noise_stats(sim)
    np.testing.assert_allclose(sim_std, real_std, rtol=0.15)
    assert sim_corr == pytest.approx(real_corr, abs=0.12)


def test_cli_realism(tmp_path, capsys):
    from liquidtouch.cli import main

    args = ["simulate", "trial", "--liquid", "water", "--height-mm", "25", "--no-video"]
    assert main([*args, "--out", str(tmp_path / "t"), "--realism", "lab", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["realism"] == "lab"
    meta = json.loads((tmp_path / "t" / "meta.json").read_text())
    assert meta["realism"]["world"] == "lab"
    assert main([*args, "--out", str(tmp_path / "u"), "--realism", "moon"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and "moon" in err[0]
    assert not (tmp_path / "u").exists()


def test_frame_gaps_are_left_out_of_the_fit(tmp_path):
    """A slow camera that drops frames in bursts: the interpolated gaps must not reach λ.

    Before gaps were gaps (``signal.py``: stretches without frames are not observed)
    this trial's λ came out at 0.081 1/s against a truth of 0.153 (the straight lines
    drawn across the gaps).
    """
    from dataclasses import replace

    from liquidtouch.extraction.pipeline import extract

    lab = Realism.lab()
    world = replace(
        Realism.clean(),
        world="slow camera",
        frame_rate_loss=lab.frame_rate_loss,
        burst_drop_probability=lab.burst_drop_probability,
    )
    trial = simulate_trial("water", height_mm=25.0, seed=2, realism=world)
    result = extract(write_trial(trial, tmp_path / "t", sensor="mini"))
    assert result.signal.gap_share > 0  # the bursts left gaps in the signal
    assert result.fit.decay_rate == pytest.approx(trial.true_decay_rate, rel=0.1)
    assert result.fit.angular_frequency == pytest.approx(trial.true_angular_frequency, rel=0.01)
