"""The live view as a viewer sees it: the page in headless Chromium while a trial streams.

A simulated trial is replayed in real time through ``live_updates`` into the
live view's server (``liquidtouch.testing.live_page``); Chromium loads the page while
the updates stream and its DOM is checked once the stream has ended: every
update arrived, each sensor's frame image decoded, the signal plot and the
plots over time were drawn, and λ, ω and the predicted properties on the page
are the stream's last values, which are near the simulator's ground truth.
Without Chromium the test skips locally and fails when the environment
variable ``CI`` is set (``.ci/run`` installs Debian's ``chromium``).
"""

from __future__ import annotations

import re

import pytest
from helpers import chromium_or_skip

from liquidtouch.testing.live_page import check_page, run_check, simulated_trial


@pytest.fixture(scope="module")
def browser() -> str:
    return chromium_or_skip()


def test_the_live_page_shows_frames_signal_and_estimates_as_they_stream(browser, tmp_path) -> None:
    trial = simulated_trial(tmp_path)
    png = tmp_path / "live.png"
    check = run_check(trial, png, browser=browser)
    assert check.problems == [], check.problems
    assert check.updates > 3 and check.signal_points > 100
    assert check.frames_loaded == len(trial[2]["sensor_names"]) == 2
    assert check.colours > 500  # frames, plots and text: not a blank page
    # what the page showed (checked equal above) against the simulator's ground truth
    meta = trial[2]
    assert check.final["angular_frequency"] == pytest.approx(
        meta["true_angular_frequency"], rel=0.01
    )
    assert abs(check.final["predicted_height_mm"] - meta["height_mm"]) < 2.0
    from PIL import Image

    with Image.open(png) as im:
        assert im.size == (1280, 900)


def test_the_check_catches_a_page_that_missed_the_stream() -> None:
    updates = [{"t_s": 1.0, "decay_rate": 0.2, "angular_frequency": 14.0, "final": True}]
    dom = (
        '<html><body data-updates="0"><div id="frames"><img data-sensor="left"></div>'
        '<svg id="signal" data-points="0"></svg>'
        '<div class="card estimate" id="est-decay_rate"><h2>λ</h2><div class="value">0.3</div>'
        "</div></body></html>"
    )
    problems = check_page(dom, updates, ["left"])
    for expected in (
        "0 of 1 updates",
        "did not see the end",
        "frame of left did not load",
        "signal plot has 0 points",
        "estimate decay_rate",
        "estimate angular_frequency",
        "plot of decay_rate over time has 0 of 1 points",
        "why the estimate stopped",
    ):
        assert any(expected in p for p in problems), (expected, problems)


def test_the_page_tolerates_sparse_and_odd_updates(browser, tmp_path) -> None:
    """Missing keys, nulls, class probabilities: the page shows what is there and goes on."""
    from liquidtouch.live.hub import LiveHub
    from liquidtouch.live.web import start_server
    from liquidtouch.testing.live_page import watch

    hub = LiveHub()
    hub.publish({})
    hub.publish({"phase": "push", "t_s": None, "signal": {"t_s": [-0.2, -0.1], "u": [0.0, 1.0]}})
    hub.publish(
        {
            "phase": "decay",
            "t_s": 1.0,
            "decay_rate": 0.31,
            "predicted_liquid": {"water": 0.8, "mirin": 0.2},  # probabilities alone
        }
    )
    hub.publish(
        {
            "phase": "done",
            "t_s": 2.0,
            "decay_rate": 0.3,
            "decay_rate_std": 0.01,
            "predicted_height_mm": 24.0,
            "predicted_liquid": "water",  # a classifier's update: the class and its probabilities
            "probability_water": 0.9,
            "probability_mirin": 0.1,
            "final": True,
            "stopped_because": "until_std",
        }
    )
    hub.close()
    with start_server(hub) as server:
        dom = watch(server.url, tmp_path / "odd.png", browser=browser)
    assert 'data-updates="4"' in dom and 'data-ended="1"' in dom
    # the newest signal came with an older update: a late browser still gets it
    assert re.search(r'id="signal"[^>]*data-points="2"', dom)
    assert "the estimates reached the requested std" in dom
    assert re.search(
        r'id="est-predicted_liquid".*?<div class="value">water</div><div class="note">p = 0\.90<',
        dom,
    )
    assert 'id="est-probability_water"' not in dom
    assert re.search(r'id="est-predicted_height_mm".*?<div class="value">24\.000</div>', dom)
    assert re.search(r'id="est-decay_rate".*?<div class="value">0\.300 ± 0\.010</div>', dom)
    assert re.search(r'id="est-angular_frequency".*?<div class="value">–</div>', dom)
