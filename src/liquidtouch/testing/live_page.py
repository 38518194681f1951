"""The live view in headless Chromium: a replayed trial served on 127.0.0.1 and what the
page shows of it.

:func:`simulated_trial` simulates a short trial (water, 25 mm, GelSight Mini videos) and a
small property model (fill height and viscosity from the simulator's ground truth);
:func:`run_check` serves the live view (:mod:`liquidtouch.live.web`) and replays the trial
through :func:`liquidtouch.live.stream.live_updates` in real time once a browser watches.
Chromium loads the page while the updates stream and dumps its DOM when the stream has
ended (``--virtual-time-budget`` holds the dump while the stream is open); a second
Chromium, arriving late, gets the history and takes the screenshot. Checks
(:func:`check_page`):

- every update reached the page and the page saw the end;
- each sensor's frame image loaded (``data-loaded`` = its decoded width);
- the signal plot and each time plot were drawn (``data-points`` on each SVG);
- λ, ω and each predicted property are on the page, as the last update says.

Used by ``tests/live/test_live_browser.py``, ``tests/live/test_live_web.py``,
:mod:`liquidtouch.testing.rig_runs` and ``benchmarks/live/live_browser.py``.
"""

from __future__ import annotations

import json
import re
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from liquidtouch.live.hub import LiveHub
from liquidtouch.live.stream import live_updates, sensor_names
from liquidtouch.live.web import start_server
from liquidtouch.models import save_model, train_regression
from liquidtouch.sim import simulate_trial, write_trial
from liquidtouch.testing.chromium import (
    ATTEMPTS,
    find_chromium,
    run_chromium,
    screenshot_colours,
)

#: the browser window, width and height [px]
WINDOW = (1280, 900)
#: how long Chromium may keep the page open, in virtual time [ms]; paused while the stream is open
BUDGET_MS = 4000


def simulated_trial(out: Path, *, duration_s: float = 6.0) -> tuple[Path, Path, dict]:
    """A water trial (25 mm, Mini videos) and a height/viscosity model file in ``out``.

    Returns (trial directory, model path, the trial's meta.json plus ``sensor_names``).
    The model is a GP on the simulator's true (λ, ω) of water and olive oil at
    16–40 mm (no videos: seconds).
    """
    out = Path(out)
    trial = simulate_trial("water", height_mm=25.0, seed=1, duration_s=duration_s)
    trial_dir = write_trial(trial, out / "trial", sensor="mini")
    sims = [
        simulate_trial(liquid, height_mm=h, seed=h, duration_s=3.0)
        for liquid in ("water", "olive-oil")
        for h in range(16, 41, 4)
    ]
    features = np.array([[s.true_decay_rate, s.true_angular_frequency] for s in sims])
    targets = {
        "height_mm": [s.height_mm for s in sims],
        "log10_viscosity_cst": [s.labels()["log10_viscosity_cst"] for s in sims],
    }
    model_path = out / "model.json"
    save_model(train_regression(features, targets, model="gpr"), model_path)
    meta = json.loads((trial_dir / "meta.json").read_text(encoding="utf-8"))
    meta["sensor_names"] = sensor_names([trial_dir])
    return trial_dir, model_path, meta


def replay_into(
    hub: LiveHub, trial_dir: Path, *, model: Path | None = None, realtime: bool = True
) -> list[dict]:
    """Feed ``hub`` the live estimate of ``trial_dir`` (updates and frames); close it at the end.

    Returns the updates published (``to_dict(include_signal=True)``).
    """

    def on_frame(frame, positions_px, reference_px) -> None:
        hub.publish_frame(frame.sensor, frame.image, reference_px, positions_px)

    published = []
    try:
        for update in live_updates(trial_dir, model=model, realtime=realtime, on_frame=on_frame):
            published.append(update.to_dict(include_signal=True))
            hub.publish(published[-1])
    finally:
        hub.close()
    return published


@dataclass
class LiveCheck:
    """What the page showed (``problems`` empty: all good)."""

    png: Path
    updates: int = 0
    signal_points: int = 0
    frames_loaded: int = 0
    colours: int = 0
    final: dict = field(default_factory=dict)  # the last update sent
    problems: list[str] = field(default_factory=list)


def attribute(dom: str, element_id: str, name: str) -> str | None:
    """The value of attribute ``name`` of the element with id ``element_id`` in ``dom``."""
    tag = re.search(rf"<[^>]*\bid=\"{re.escape(element_id)}\"[^>]*>", dom)
    value = re.search(rf"\b{name}=\"([^\"]*)\"", tag.group(0)) if tag else None
    return value.group(1) if value else None


def estimate_text(dom: str, key: str) -> str | None:
    """The text of the big value of estimate card ``key`` (e.g. ``decay_rate``)."""
    found = re.search(rf"id=\"est-{re.escape(key)}\".*?<div class=\"value\">([^<]*)</div>", dom)
    return found.group(1) if found else None


def _shows(text: str, value: float) -> bool:
    """Whether ``text`` ("0.215 ± 0.010") starts with ``value`` rounded to its decimals."""
    shown = re.match(r"\s*(-?\d+)(?:\.(\d+))?", text)
    if shown is None:
        return False
    decimals = len(shown.group(2) or "")
    return abs(float(shown.group(0)) - value) <= 0.5 * 10.0**-decimals * (1 + 1e-9)


def check_page(dom: str, updates: list[dict], sensors: list[str]) -> list[str]:
    """Problems of the dumped DOM ``dom`` of a page that was sent ``updates``."""
    problems = []
    body = re.search(r"<body[^>]*>", dom)
    body_tag = body.group(0) if body else ""
    shown = re.search(r"data-updates=\"(\d+)\"", body_tag)
    if not shown or int(shown.group(1)) != len(updates):
        problems.append(f"the page shows {shown and shown.group(1)} of {len(updates)} updates")
    if 'data-ended="1"' not in body_tag:
        problems.append("the page did not see the end of the stream")
    for sensor in sensors:
        img = re.search(rf"<img[^>]*data-sensor=\"{re.escape(sensor)}\"[^>]*>", dom)
        loaded = re.search(r"data-loaded=\"(\d+)\"", img.group(0)) if img else None
        if not loaded or int(loaded.group(1)) <= 0:
            problems.append(f"the frame of {sensor} did not load")
    points = int(attribute(dom, "signal", "data-points") or 0)
    if points < 50:
        problems.append(f"the signal plot has {points} points")
    last = updates[-1] if updates else {}
    keys = ["decay_rate", "angular_frequency"]
    keys += [k for k in last if k.startswith("predicted_") and not k.endswith("_std")]
    for key in keys:
        text, value = estimate_text(dom, key), last.get(key)
        if text is None or (isinstance(value, float) and not _shows(text, value)):
            problems.append(f"estimate {key}: the page shows {text!r}, the stream {value!r}")
        expected = sum(
            isinstance(u.get("t_s"), float) and isinstance(u.get(key), float) for u in updates
        )
        drawn = int(attribute(dom, f"plot-{key}", "data-points") or 0)
        if drawn != expected or not expected:
            problems.append(f"the plot of {key} over time has {drawn} of {expected} points")
    if last.get("final") and "stopped:" not in dom:
        problems.append("the page does not say why the estimate stopped")
    return problems


def watch(url: str, png: Path, *, browser: str | None = None, timeout_s: float = 60) -> str:
    """Load ``url`` in Chromium until its stream ends; return the DOM (and screenshot ``png``).

    The two Chromium runs are concurrent: the DOM one arrives first; the screenshot one
    may arrive late (it then gets the history).
    """
    browser = browser or find_chromium()
    if browser is None:
        raise FileNotFoundError("no chromium on PATH")
    common = (f"--virtual-time-budget={BUDGET_MS}", f"--window-size={WINDOW[0]},{WINDOW[1]}")
    shot: dict = {}

    def screenshot() -> None:
        png.unlink(missing_ok=True)
        done = run_chromium(
            browser, *common, f"--screenshot={png.resolve()}", url, timeout=timeout_s
        )
        shot["stderr"] = done.stderr

    thread = threading.Thread(target=screenshot)
    thread.start()
    done = run_chromium(browser, *common, "--dump-dom", url, timeout=timeout_s)
    thread.join(timeout_s * ATTEMPTS + 10)
    if not done.stdout.strip():
        raise RuntimeError(f"chromium dumped no DOM (exit {done.returncode}): {done.stderr}")
    if not png.is_file():
        raise RuntimeError(f"chromium wrote no screenshot: {shot.get('stderr')}")
    return done.stdout


def run_check(
    trial: tuple[Path, Path, dict], png: Path, *, browser: str | None = None
) -> LiveCheck:
    """Serve ``trial`` = (trial dir, model, meta) live, watch it in Chromium, check the page."""
    trial_dir, model_path, meta = trial
    hub = LiveHub()
    published: list[dict] = []
    with start_server(hub) as server:

        def replay() -> None:
            deadline = time.monotonic() + 60  # wait for a browser: it must see the stream live
            while server.readers < 1 and time.monotonic() < deadline:
                time.sleep(0.02)
            published.extend(replay_into(hub, trial_dir, model=model_path, realtime=True))

        feeder = threading.Thread(target=replay)
        feeder.start()
        try:
            dom = watch(server.url, Path(png), browser=browser)
        finally:
            hub.close()
            feeder.join(120)
    check = LiveCheck(png=Path(png), problems=check_page(dom, published, meta["sensor_names"]))
    check.updates = len(published)
    check.final = published[-1] if published else {}
    check.signal_points = int(attribute(dom, "signal", "data-points") or 0)
    check.frames_loaded = len(re.findall(r"data-loaded=\"[1-9]\d*\"", dom))
    check.colours = screenshot_colours(check.png)
    if check.colours < 500:
        check.problems.append(f"the screenshot has {check.colours} colours: blank?")
    return check
