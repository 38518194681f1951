"""A camera that watches the whole trial: a grasp or lift before the push, a camera that dies.

Synthetic marker frames (``helpers.render_blobs``) move all markers by a known
displacement: a step at 3 s (the lift: a new shear load that relaxes without
ringing) and a damped oscillation from 7 s (the push: λ = 0.5 /s, ω = 12 rad/s).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import grid, render_blobs

from liquidtouch.errors import DeviceError
from liquidtouch.live import LiveFrame, live_updates

FPS = 30.0
LIFT_S, PUSH_S = 3.0, 7.0
DECAY_RATE, ANGULAR_FREQUENCY = 0.5, 12.0


def _displacement_px(t: np.ndarray) -> np.ndarray:
    lift = np.where(t > LIFT_S, 2.5 * (1 - np.exp(-(t - LIFT_S) / 0.15)), 0.0)
    tau = t - PUSH_S
    push = np.where(tau > 0, 1.2 * np.exp(-DECAY_RATE * tau) * np.sin(ANGULAR_FREQUENCY * tau), 0)
    return lift + push


def _frames(duration_s: float, fail_after_s: float = math.inf):
    centres = grid()
    t = np.arange(0.0, duration_s, 1 / FPS)
    for k, (t_s, dx) in enumerate(zip(t, _displacement_px(t), strict=True)):
        if t_s > fail_after_s:
            raise DeviceError("camera left failed: no data within 2 s")
        moved = centres + np.array([dx, 0.0])
        yield LiveFrame("left", float(t_s), render_blobs(moved, noise=2.0, seed=k))


@pytest.fixture(scope="module")
def updates():
    return list(live_updates(_frames(15.0), sensors=["left"]))


def test_a_lift_before_the_push_is_not_taken_for_it(updates) -> None:
    streamed = [u for u in updates if not u.final and math.isfinite(u.decay_rate)]
    assert streamed, "no streamed estimate"
    # every streamed estimate comes from the push's ring-down, not the lift's relaxation
    for update in streamed:
        assert update.angular_frequency == pytest.approx(ANGULAR_FREQUENCY, rel=0.02)
    final = updates[-1]
    assert final.decay_rate == pytest.approx(DECAY_RATE, rel=0.10)
    assert final.angular_frequency == pytest.approx(ANGULAR_FREQUENCY, rel=0.005)


def test_a_camera_that_dies_mid_stream_keeps_the_estimate_so_far() -> None:
    updates = list(live_updates(_frames(15.0, fail_after_s=12.0), sensors=["left"]))
    final = updates[-1]
    assert final.final and final.stopped_because == "source_error"
    assert "no data within 2 s" in final.message
    assert final.angular_frequency == pytest.approx(ANGULAR_FREQUENCY, rel=0.01)


def test_a_camera_that_fails_before_any_frame_raises() -> None:
    with pytest.raises(DeviceError):
        list(live_updates(_frames(1.0, fail_after_s=-1.0), sensors=["left"]))
