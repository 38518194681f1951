"""Experiment 9's bookkeeping: when an answer is right for good, which trials are replayed.

The replay itself (a sugar-water trial through the live estimator, the report's section) is
run end to end by ``test_experiments.py::test_reproduce_end_to_end_through_videos``.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from liquidtouch.experiments.time_to_answer import pick_trials, settle_time_s


def test_right_for_good_from_the_first_estimate_after_the_last_wrong_one() -> None:
    t = np.array([1.0, 1.25, 1.5, 1.75, 2.0])
    assert settle_time_s(t, np.array([False, True, False, True, True])) == 1.75
    assert settle_time_s(t, np.ones(5, bool)) == 1.0
    # the last estimate is still wrong, or there is none: never
    assert settle_time_s(t, np.array([True, True, True, True, False])) == math.inf
    assert settle_time_s(t[:0], np.zeros(0, bool)) == math.inf


def test_replayed_trials_span_the_fill_heights() -> None:
    test = pd.DataFrame({"trial": [f"t{k}" for k in range(10)], "height_mm": np.arange(10.0)[::-1]})
    chosen = pick_trials(test, 3)
    assert list(chosen["height_mm"]) == [0.0, 4.0, 9.0]  # lowest, middle, highest
    assert len(pick_trials(test, 20)) == 10  # all of them when fewer than asked
