"""Streaming estimation with early stopping: frames in, estimates with their std out.

Frames (live cameras, or a recording replayed at its own pace) are tracked one
at a time; every ~0.25 s of stream the tactile signal is rebuilt, the push and
the start of the free decay are found, the decay is fitted and — with a model —
the properties are predicted with the fit's uncertainty propagated. An
estimate is reported as soon as its std supports it, and the stream stops
early once every requested target's std is below a threshold.

One concept per module:

- :mod:`~liquidtouch.live.sources`: timed frames (:class:`LiveFrame`) from
  recordings (:func:`replay_frames`) or cameras (:func:`camera_frames`);
- :mod:`~liquidtouch.live.tracks`: marker tracks growing frame by frame;
- :mod:`~liquidtouch.live.refresh`: one refresh (signal, phase, fit);
- :mod:`~liquidtouch.live.uncertainty`: the std of a streamed λ, ω (how far from
  the final values they may still be; calibrated on simulated trials);
- :mod:`~liquidtouch.live.properties`: predictions with the fit's std propagated
  (a liquid classifier's probabilities too);
- :mod:`~liquidtouch.live.calibration`: ±kσ coverage, to check a std means what it says;
- :mod:`~liquidtouch.live.estimator`: :class:`LiveEstimator` (``add_frame``,
  ``finish``) and the emission rule;
- :mod:`~liquidtouch.live.stopping`: ``--until-std`` thresholds and the stop rule;
- :mod:`~liquidtouch.live.updates`: :class:`LiveUpdate`, what is reported;
- :mod:`~liquidtouch.live.stream`: :func:`live_updates`, the loop.

Example::

    from liquidtouch.live import live_updates

    for update in live_updates("trial_dir", model="model.json",
                               until_std={"height_mm": 0.5}):
        print(update.t_s, update.decay_rate, update.predicted)
"""

from __future__ import annotations

from liquidtouch._core.lazy import lazy_exports

__all__ = [
    "PHASES",
    "REFRESH_S",
    "LiveEstimator",
    "LiveFrame",
    "LiveUpdate",
    "camera_frames",
    "check_live_request",
    "check_until_std",
    "live_updates",
    "open_frames",
    "parse_until_std",
    "replay_frames",
    "sensor_names",
    "stop_reached",
    "unreachable_message",
]

_LAZY = {
    "PHASES": "liquidtouch.live.updates",
    "REFRESH_S": "liquidtouch.live.estimator",
    "LiveEstimator": "liquidtouch.live.estimator",
    "LiveFrame": "liquidtouch.live.sources",
    "LiveUpdate": "liquidtouch.live.updates",
    "camera_frames": "liquidtouch.live.sources",
    "check_live_request": "liquidtouch.live.properties",
    "check_until_std": "liquidtouch.live.stopping",
    "live_updates": "liquidtouch.live.stream",
    "open_frames": "liquidtouch.live.sources",
    "parse_until_std": "liquidtouch.live.stopping",
    "replay_frames": "liquidtouch.live.sources",
    "sensor_names": "liquidtouch.live.stream",
    "stop_reached": "liquidtouch.live.stopping",
    "unreachable_message": "liquidtouch.live.stopping",
}


# lazy (PEP 562), as the ring-down face: the command line checks --until-std (stopping)
# before SciPy, scikit-learn and the estimator are imported, so a typo is answered at once
__getattr__ = lazy_exports(__name__, _LAZY)
