"""Ring-downs of one bottle combined by their ±: weights, the consistency check, the floor;
and "cannot tell here" (models.reach, PropertyModel.reach) on an upright bottle's physics."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from liquidtouch._core.containers import get_container
from liquidtouch._core.liquids import get_liquid
from liquidtouch.errors import SignalError, TableError
from liquidtouch.models.combine import RingDownEstimate, combine_ring_downs
from liquidtouch.models.reach import FIT_FLOOR, reach_of
from liquidtouch.models.training import train_regression
from liquidtouch.sim.slosh import slosh_system

LAM, OMEGA = 1.2, 14.0


def _draws(rng, n, s_lam, s_omega, lam=LAM, omega=OMEGA):
    return [
        RingDownEstimate(lam + rng.normal(0, s), s, omega + rng.normal(0, w), w)
        for s, w in zip(s_lam, s_omega, strict=True)
    ][:n]


def test_weighted_mean_and_std_are_inverse_variance():
    items = [RingDownEstimate(1.0, 0.1, 14.0, 0.2), RingDownEstimate(1.2, 0.2, 14.3, 0.4)]
    c = combine_ring_downs(items)
    w = np.array([100.0, 25.0])
    assert c.decay_rate == pytest.approx((w @ [1.0, 1.2]) / w.sum())
    assert c.decay_rate_std == pytest.approx(1 / math.sqrt(w.sum()))
    wo = np.array([25.0, 6.25])
    assert c.angular_frequency == pytest.approx((wo @ [14.0, 14.3]) / wo.sum())
    assert c.consistent and c.n == 2 and c.outliers == ()


def test_one_ring_down_is_its_own_estimate_and_unusable_ones_are_left_out():
    one = {"decay_rate": 1.0, "decay_rate_std": 1e-6, "angular_frequency": 14.0,
           "angular_frequency_std": 1e-6}  # fmt: skip
    bad = {**one, "decay_rate_std": float("nan")}
    c = combine_ring_downs([bad, one])
    assert c.used == (1,) and c.n == 1 and c.consistent
    assert (c.decay_rate, c.angular_frequency) == (1.0, 14.0)
    assert c.decay_rate_std == pytest.approx(FIT_FLOOR[0])  # floored, as a combination is
    loose = combine_ring_downs([{**one, "decay_rate_std": 0.3}])
    assert loose.decay_rate_std == 0.3
    with pytest.raises(SignalError, match="no ring-down"):
        combine_ring_downs([bad])
    with pytest.raises(SignalError, match="as numbers"):
        combine_ring_downs([{"decay_rate": 1.0}])


def test_combined_std_covers_the_truth_and_false_alarms_are_rare():
    rng = np.random.default_rng(3)
    inside = alarms = 0
    runs = 2000
    for _ in range(runs):
        s_lam = rng.uniform(0.05, 0.2, 3)
        s_om = rng.uniform(0.05, 0.3, 3)
        c = combine_ring_downs(_draws(rng, 3, s_lam, s_om))
        inside += abs(c.angular_frequency - OMEGA) <= 2 * c.angular_frequency_std
        alarms += not c.consistent
    assert 0.93 <= inside / runs <= 0.98  # ±2σ of a Gaussian: 95.4 %
    assert alarms / runs <= 0.035  # two features at a 1 % level each


def test_disagreeing_ring_downs_are_reported_and_widen_the_std():
    items = [RingDownEstimate(1.2, 0.05, 14.0, 0.05) for _ in range(2)]
    items.append(RingDownEstimate(1.2, 0.05, 15.0, 0.05))  # 20σ off in ω
    c = combine_ring_downs(items)
    assert not c.consistent and c.outliers == (2,)
    assert "disagree" in c.message() and "push 3" in c.message()
    spread = np.std([14.0, 14.0, 15.0], ddof=1)
    assert c.angular_frequency_std > 0.5 * spread / math.sqrt(3)  # the spread, not the claim
    assert c.angular_frequency_std > 10 * 0.05 / math.sqrt(3)


def test_many_precise_ring_downs_never_go_below_the_fit_floor():
    items = [RingDownEstimate(1.2, 1e-4, 14.0, 1e-4) for _ in range(5)]
    c = combine_ring_downs(items)
    assert c.decay_rate_std == pytest.approx(FIT_FLOOR[0] * 1.2)
    assert c.angular_frequency_std == pytest.approx(FIT_FLOOR[1] * 14.0)
    # adding a ring-down never widens a consistent answer
    rng = np.random.default_rng(5)
    for _ in range(200):
        draws = _draws(rng, 3, rng.uniform(0.001, 0.1, 3), rng.uniform(1e-4, 0.05, 3))
        stds = [combine_ring_downs(draws[:k]) for k in (1, 2, 3)]
        for a, b in itertools.pairwise(stds):
            if b.consistent:
                assert b.angular_frequency_std <= a.angular_frequency_std * (1 + 1e-12) or (
                    b.angular_frequency_std == pytest.approx(FIT_FLOOR[1] * b.angular_frequency)
                )


def test_reach_arithmetic():
    # one push gives ±1.0 through the model, the model itself ±0.3: 0.5 needs > 1/(0.25-0.09)
    r = reach_of("h", 0.5, model_std=0.3, fit_std=1.0, floor_std=0.1, pushes=1)
    assert not r.met and not r.cannot_tell and r.pushes_needed == 7
    assert math.hypot(0.3, 1.0 / math.sqrt(7)) < 0.5 < math.hypot(0.3, 1.0 / math.sqrt(6))
    assert reach_of("h", 0.5, model_std=0.6, fit_std=0.1, floor_std=0.0, pushes=1).reason == "model"
    s = reach_of("h", 0.5, model_std=0.1, fit_std=5.0, floor_std=0.8, pushes=2)
    assert s.reason == "sensitivity" and s.pushes_needed is None and "whatever" in s.message
    d = reach_of("h", 0.5, model_std=0.1, fit_std=0.1, floor_std=0.0, pushes=1, in_domain=False)
    assert d.reason == "domain" and d.cannot_tell
    assert reach_of("h", 0.5, model_std=0.1, fit_std=0.2, floor_std=0.0, pushes=3).met


def _upright_model(top_mm: float):
    """A height GP of the upright bottle, trained on its physics (λ, ω) at 10-``top_mm`` mm
    of four liquids with 0.1 % noise on ω (what a few good pushes give)."""
    box = get_container("upright-bottle")
    rng = np.random.default_rng(0)
    rows, heights = [], []
    for name in ("water", "mirin", "olive-oil", "corn-oil"):
        for h in np.linspace(10, top_mm, 16):
            lam, omega = slosh_system(get_liquid(name), box, h).slow_mode()
            rows.append([lam * (1 + rng.normal(0, 0.02)), omega * (1 + rng.normal(0, 1e-3))])
            heights.append(h)
    X = np.array(rows)
    std = np.abs(X) * [0.02, 1e-3]
    return train_regression(X, {"height_mm": np.array(heights)}, calibration_folds=5,
                            calibration_groups=np.array(heights), calibration_std=std)  # fmt: skip


@pytest.fixture(scope="module")
def whole_bottle():
    return _upright_model(190.0)


@pytest.fixture(scope="module")
def lower_part():
    return _upright_model(60.0)


@pytest.mark.parametrize("height", [120.0, 170.0])
@pytest.mark.parametrize("trained", ["whole_bottle", "lower_part"])
def test_upright_bottle_filled_deep_cannot_tell(trained, height, request):
    upright_model = request.getfixturevalue(trained)
    lam, omega = slosh_system(
        get_liquid("water"), get_container("upright-bottle"), height
    ).slow_mode()
    X = np.array([[lam, omega]])
    for pushes, std in ((1, 0.02), (3, 1e-4)):  # even three pushes with a tiny fit std
        for asked in (0.5, 2.0):
            r = upright_model.reach(X, np.abs(X) * std, {"height_mm": asked}, pushes=pushes)
            assert r["height_mm"].cannot_tell, r["height_mm"]
    # the model of the lower part extrapolates: its answer lies beyond its training range
    if trained == "lower_part":
        assert r["height_mm"].reason == "domain"


def test_upright_bottle_shallow_fill_is_reachable(lower_part):
    upright_model = lower_part
    lam, omega = slosh_system(
        get_liquid("water"), get_container("upright-bottle"), 20.0
    ).slow_mode()
    X = np.array([[lam, omega]])
    r = upright_model.reach(X, np.abs(X) * [0.02, 1e-3], {"height_mm": 2.0})["height_mm"]
    assert not r.cannot_tell, r.message
    with pytest.raises(TableError, match="does not predict"):
        upright_model.reach(X, None, {"sugar_concentration": 1.0})
