"""`live` watching the simulated rig's cameras while `run-trial` runs a trial (issue 21).

The README's order: ``liquidtouch rig serve`` (a subprocess, as on another machine), the
live estimate of its two MJPEG streams started at some moment — before ``run-trial``
(``before``, the README order), once the bottle is lifted (``lifted``) or when the push
starts (``push``) — and ``run-trial`` (a subprocess, ``-v``: its log says when each
protocol event happens). ``live`` gets no protocol events (it segments the stream on its
own); it is stopped a few seconds after ``run-trial`` has put the bottle down and
released it, and its final update is compared with the rig's truth.

A run succeeds when the standing estimate is within 5 % (λ) and 1 % (ω) of the truth, or
says "no ring-down found"; any other number is a wrong answer. ``tests/live/test_live_rig.py``
runs one or two; ``benchmarks/live/rig_live.py --runs 10`` gives the statistics.
"""

from __future__ import annotations

import json
import math
import re
import select
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from liquidtouch.live.stream import live_updates
from liquidtouch.models import save_model, train_classifier
from liquidtouch.sim import simulate_trial
from liquidtouch.testing.live_page import attribute, estimate_text, watch

LIQUID = {"liquid": "mirin", "height_mm": 25.0, "seed": 1}
STARTS = ("before", "lifted", "push")
#: λ and ω tolerances of a right answer (relative)
TOL_DECAY, TOL_FREQ = 0.05, 0.01
#: a gap between one sensor's frames longer than this [s] means the rig's cameras stalled
STALL_S = 0.25
EVENT = re.compile(r"event (\w+) at ([0-9.]+) s")
CLI = [sys.executable, "-c", "from liquidtouch.cli import run; run()"]


@contextmanager
def rig_serving(**liquid: object) -> Iterator[dict]:
    """``rig serve --json`` in a subprocess; yields its endpoints (and truth). ``liquid``:
    ``liquid``, ``height_mm``, ``seed`` (default :data:`LIQUID`), ``sugar_concentration``,
    ``container``."""
    spec = {**LIQUID, **liquid}
    argv = [
        *CLI,
        "rig",
        "serve",
        "--liquid",
        spec["liquid"],
        "--height-mm",
        str(spec["height_mm"]),
        "--seed",
        str(spec["seed"]),
        "--sensor",
        "mini",
        "--json",
    ]
    for key in ("sugar_concentration", "container"):  # optional: sugar water, other bottles
        if spec.get(key) is not None:
            argv += [f"--{key.replace('_', '-')}", str(spec[key])]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 90
        while True:
            if proc.poll() is not None:
                raise RuntimeError(f"rig serve exited: {proc.stderr.read()}")
            if time.monotonic() > deadline:
                raise RuntimeError("rig serve printed no endpoints in 90 s")
            ready, _, _ = select.select([proc.stdout], [], [], 0.5)
            if ready and (line := proc.stdout.readline()).strip():
                yield json.loads(line)
                return
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=10)


class LiveWatcher:
    """``live_updates`` of the rig's cameras on a thread (as ``liquidtouch live`` runs it)."""

    def __init__(self, cameras: list[str]) -> None:
        self.cameras = cameras
        self.stop_event = threading.Event()
        self.updates: list[dict] = []
        self.frame_times: dict[str, list[float]] = {}
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._run, name="live-watcher", daemon=True)

    def _on_frame(self, frame, *_):
        self.frame_times.setdefault(frame.sensor, []).append(frame.t_s)

    def _run(self) -> None:
        try:
            for update in live_updates(
                self.cameras, on_frame=self._on_frame, stop=self.stop_event.is_set
            ):
                self.updates.append(update.to_dict())
        except BaseException as exc:  # kept for the caller
            self.error = exc

    def start(self) -> LiveWatcher:
        self.started_at = time.monotonic()
        self.thread.start()
        return self

    def finish(self, timeout_s: float = 60.0) -> dict:
        self.stop_event.set()
        self.thread.join(timeout_s)
        if self.error is not None:
            raise self.error
        if not self.updates or not self.updates[-1]["final"]:
            raise RuntimeError("live gave no final update")
        return self.updates[-1]

    def longest_gap_s(self) -> float:
        gaps = [np.diff(t).max() for t in self.frame_times.values() if len(t) > 1]
        return float(max(gaps, default=math.inf))


def run_once(endpoints: dict, start: str, out: Path, *, hold_s: float = 9.0,
             after_s: float = 3.0) -> dict:  # fmt: skip
    """One trial with ``live`` started at ``start`` (one of :data:`STARTS`); its summary."""
    if start not in STARTS:
        raise ValueError(f"start must be one of {STARTS}, got {start!r}")
    cameras = list(endpoints["cameras"].values())
    argv = [*CLI, "-v", "run-trial", "--gripper", endpoints["gripper"], "--arm",
            endpoints["arm"], "--out", str(out), "--seconds", str(hold_s)]  # fmt: skip
    for url in cameras:
        argv += ["--camera", url]
    watcher = LiveWatcher(cameras)
    if start == "before":
        watcher.start()
        time.sleep(1.0)
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    events: dict[str, float] = {}
    log = []
    try:
        for line in proc.stderr:
            log.append(line)
            if match := EVENT.search(line):
                events[match[1]] = float(match[2])
                trigger = {"lifted": "recording", "push": "push"}.get(start)
                if match[1] == trigger and not watcher.thread.is_alive():
                    watcher.start()
        proc.wait(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    if proc.returncode != 0 or not watcher.thread.is_alive():
        watcher.finish()
        raise RuntimeError(f"run-trial failed ({proc.returncode}): {''.join(log[-5:])}")
    time.sleep(after_s)  # the bottle stands on the table: the stream goes on a little
    final = watcher.finish()
    truth = endpoints["truth"]
    lam, omega = final["decay_rate"], final["angular_frequency"]
    err_lam = lam / truth["true_decay_rate"] - 1 if lam is not None else None
    err_omega = omega / truth["true_angular_frequency"] - 1 if omega is not None else None
    none_found = final["message"].startswith("no ring-down found")
    right = err_lam is not None and abs(err_lam) < TOL_DECAY and abs(err_omega) < TOL_FREQ
    return {
        "start": start,
        "outcome": "right" if right else "none found" if none_found else "wrong",
        "err_decay_rate": err_lam,
        "err_angular_frequency": err_omega,
        "segment_final": final["segment_final"],
        "segments": len(final["segments"]),
        "message": final["message"],
        "longest_gap_s": watcher.longest_gap_s(),
        "live_started_after_push_s": watcher.started_at - events["push"]
        if "push" in events
        else None,
        "events": events,
    }


SERVING = re.compile(r"serving the live view at (http://\S+)")


def served_run_trial(endpoints: dict, out: Path, png: Path, *, browser: str | None = None,
                     hold_s: float = 9.0, model: Path | None = None) -> dict:  # fmt: skip
    """``run-trial --live --serve 127.0.0.1:0`` watched in headless Chromium from the moment
    it serves; the page's DOM (dumped once the stream ended), a screenshot and the trial."""
    argv = [*CLI, "-v", "run-trial", "--gripper", endpoints["gripper"], "--arm",
            endpoints["arm"], "--out", str(out), "--seconds", str(hold_s), "--live",
            "--serve", "127.0.0.1:0"]  # fmt: skip
    for url in endpoints["cameras"].values():
        argv += ["--camera", url]
    if model is not None:
        argv += ["--model", str(model)]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    page: dict = {}
    watcher = None
    log = []
    try:
        for line in proc.stderr:
            log.append(line)
            if watcher is None and (match := SERVING.search(line)):

                def look(url=match[1]) -> None:
                    try:
                        page["dom"] = watch(url, png, browser=browser, timeout_s=180)
                    except Exception as exc:  # reported by the caller
                        page["error"] = exc

                watcher = threading.Thread(target=look)
                watcher.start()
        proc.wait(timeout=180)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        if watcher is not None:
            watcher.join(200)
    if proc.returncode != 0:
        raise RuntimeError(f"run-trial failed ({proc.returncode}): {''.join(log[-5:])}")
    if "error" in page or "dom" not in page:
        raise RuntimeError(f"the page could not be watched: {page.get('error')}")
    dom = page["dom"]
    live = json.loads((out / "live.json").read_text())
    body = re.search(r"<body[^>]*>", dom).group(0)
    shown = {key: estimate_text(dom, key) for key in ("decay_rate", "angular_frequency")}
    return {
        "dom": dom,
        "live": live,
        "ended": 'data-ended="1"' in body,
        "updates_shown": int(re.search(r'data-updates="(\d+)"', body).group(1)),
        "signal_points": int(attribute(dom, "signal", "data-points") or 0),
        "events_drawn": int(attribute(dom, "signal", "data-events") or 0),
        "shown": shown,
        "phase": attribute(dom, "phase", "class"),
        "liquid": estimate_text(dom, "predicted_liquid"),
        "domain": re.search(r'<span id="domain">([^<]*)</span>', dom).group(1),
        "out_of_domain": ood[1]
        if (ood := re.search(r'data-out-of-domain="([01]?)"', body))
        else None,
    }


def simulated_classifier(
    path: Path, liquids: tuple[str, ...] = ("water", "olive-oil", "detergent")
) -> Path:
    """A classifier file trained on the simulator's truth (4 trials at each of 8 heights
    20-40 mm per liquid, with the fit's typical noise: λ 4 %, ω 0.3 %)."""
    rng = np.random.default_rng(3)
    X, labels = [], []
    for liquid in liquids:
        for h in np.linspace(20, 40, 8):
            for rep in range(4):
                trial = simulate_trial(liquid, height_mm=float(h), seed=int(h) + 100 * rep,
                                       duration_s=3.0)  # fmt: skip
                lam = trial.true_decay_rate * np.exp(0.04 * rng.standard_normal())
                omega = trial.true_angular_frequency * (1 + 0.003 * rng.standard_normal())
                X.append((lam, omega))
                labels.append(liquid)
    return save_model(train_classifier(np.array(X), labels), path)
