"""Several pushes in one stream (issue 40): each ring-down final on its own, all combined by
their ± the same way as the API (``liquidtouch.combine_ring_downs``), with the model's
answer and whether the asked ± is reachable.

The protocol is simulated at the marker level (``liquidtouch.sim.protocol_scene`` with
``pushes``: every push restarts the slosh with fresh contact noise, back and forth).
"""

from __future__ import annotations

import numpy as np
import pytest

import liquidtouch
from liquidtouch.live.estimator import LiveEstimator
from liquidtouch.models.reach import FIT_FLOOR
from liquidtouch.sim.protocol_scene import ProtocolTimings, protocol_scene

SENSORS = ("left", "right")


def _stream(scene, **kwargs):
    estimator = LiveEstimator(list(SENSORS), protocol=True, **kwargs)
    pending = list(scene.event_sequence)
    updates = []
    for k, t_s in enumerate(scene.t):
        while pending and pending[0][1] <= t_s:
            estimator.add_event(*pending.pop(0))
        for s, name in enumerate(SENSORS):
            update = estimator.add_markers(name, t_s + 1e-3 * s, scene.positions[s, k])
            if update is not None:
                updates.append(update)
    updates.append(estimator.finish())
    return updates


@pytest.fixture(scope="module")
def three_pushes():
    timings = ProtocolTimings(hold_s=5.0, pushes=3)
    return protocol_scene("mirin", height_mm=25, seed=1, timings=timings)


def test_event_sequence_of_several_pushes(three_pushes) -> None:
    names = [n for n, _ in three_pushes.event_sequence]
    assert names.count("push") == 3 and names.count("hold_end") == 2
    times = [t for _, t in three_pushes.event_sequence]
    assert times == sorted(times)
    single = ProtocolTimings()
    assert single.events() == dict(single.event_sequence())  # one push: as before


@pytest.mark.slow(seconds=50)
@pytest.mark.timeout(600)
def test_three_ring_downs_final_and_combined(three_pushes) -> None:
    scene = three_pushes
    updates = _stream(scene)
    final = updates[-1]
    assert [s["segment"] for s in final.segments] == [1, 2, 3]
    combined = final.combined
    assert combined["ring_downs"] == 3 and combined["consistent"], combined
    # the same combination as the API's, from the segments' own estimates
    api = liquidtouch.combine_ring_downs(final.segments)
    assert combined["angular_frequency"] == pytest.approx(api.angular_frequency)
    assert combined["decay_rate_std"] == pytest.approx(api.decay_rate_std)
    lam, omega = scene.true_decay_rate, scene.true_angular_frequency
    assert abs(combined["angular_frequency"] - omega) < max(
        3 * combined["angular_frequency_std"], 0.005 * omega
    )
    assert combined["decay_rate"] == pytest.approx(lam, rel=0.1)
    singles = np.array([s["angular_frequency_std"] for s in final.segments])
    floor = FIT_FLOOR[1] * combined["angular_frequency"]
    assert combined["angular_frequency_std"] <= max(singles.min(), floor) * (1 + 1e-9)
    # each ring-down's estimate is its own (never replaced by the combination)
    assert len({s["angular_frequency"] for s in final.segments}) == 3
    assert "combined" in final.to_dict()


def test_next_push_decision() -> None:
    from liquidtouch.live.combined import next_push

    def reach(met, cannot, msg="m"):
        return {"met": met, "cannot_tell": cannot, "message": msg}

    assert next_push({}) == (True, "no ring-down estimate to judge yet")
    again, why = next_push({"reach": {"height_mm": reach(False, False, "±0.8, about 3")}})
    assert again and "about 3" in why
    stop, why = next_push({"reach": {"a": reach(True, False), "b": reach(False, True, "deep")}})
    assert not stop and why == "deep"
    done, why = next_push({"reach": {"a": reach(True, False)}})
    assert not done and why.startswith("every target met")


def test_answer_line_of_several_pushes() -> None:
    from liquidtouch.cli.live import answer_line

    reach = {"met": False, "cannot_tell": False, "message": "height_mm: ±0.8, about 5 push(es)"}
    combined = {
        "ring_downs": 3,
        "message": "3 ring-downs combined, consistent",
        "predicted": {"height_mm": [25.1234, 0.81]},
        "reach": {"height_mm": reach},
    }
    line = answer_line({"combined": combined})
    assert line.startswith("answer: height_mm = 25.12 ± 0.81 (3 ring-downs")
    assert "not met: height_mm" in line
    told = {**reach, "cannot_tell": True, "message": "cannot tell height_mm to ±0.5 here"}
    one = {"ring_downs": 1, "reach": {"height_mm": told}, "predicted": {}}
    assert answer_line({"combined": one}) == "answer: cannot tell height_mm to ±0.5 here"
    assert answer_line({"combined": {"ring_downs": 1, "reach": {}}}) is None
