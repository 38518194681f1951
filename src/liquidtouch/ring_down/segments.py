"""The trial's segments and the ring-down to fit.

Trial segments
--------------
A recording that watches a whole trial holds more than the push: the grasp, the
lift, the lowering and the release move the markers too, often further than the
push. :func:`trial_segments` splits the signal into **rest**, **transients**, the
**push**, its **ring-down** and the **release** (the end of the hold), one function
for ``extract``, ``features`` and ``live``:

1. **Transients** (:func:`find_transients`): the activity (the high-passed signal's
   distance from its resting level, over every channel given) *rises*: a sample
   exceeds ``RISE_RATIO`` × the largest activity of the ``RISE_WINDOW_S`` ending
   ``RISE_LAG_S`` before it plus ``RISE_NOISE`` noise levels. A free decay never rises
   above its own previous period, so a ring-down is never cut by its own oscillation;
   the end of the hold (a large step, not a decay) is a rise.
2. **Ring-downs**: after each transient, from its largest excursion (within
   ``PEAK_S``: the push and the liquid's lag) to ``GUARD_S`` before the next transient
   (or the end of the signal), the candidate is a ring-down when it is a decaying
   oscillation in the slosh band (:func:`~liquidtouch.ring_down.check.ring_down_reason`:
   the single-mode fit finds an oscillation above the noise, ω ≥ 3 λ, three half-cycles
   stand out, and the signal follows the fitted free decay) — not "the largest
   excursion".
   The transient it follows is the **push**; a transient after a ring-down is a
   **release**; the others are **transients** (grasp, lift).
3. **A signal that begins inside a ring-down** (a camera started late, a recording cut
   after the push) is a ring-down from its first samples (after the filters' edge,
   ``EDGE_S``) when that stretch is a decaying oscillation; else the stretch before the
   first transient is judged from its own largest excursion (a push not told apart).
4. **Known events** (``events``: the protocol's times on the signal's clock, as
   :func:`~liquidtouch.acquire.protocol.run_trial` logs them): the push and the end of
   the hold are taken from them (no guessing); the ring-down runs from the largest
   excursion after the push's start to ``GUARD_S`` before the hold ends.

:func:`free_decay` fits the chosen ring-down (:func:`chosen_ring_down`: the last one of at
least ``MIN_FREE_DECAY_S``, else the longest); on a recording of a push and a hold only
(the simulated trials) that is, as before, the largest excursion to the end.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from liquidtouch._core.checks import check_times, finite_array
from liquidtouch.errors import SignalError
from liquidtouch.ring_down.check import MIN_CANDIDATE_S, ring_down_reason
from liquidtouch.ring_down.start import (
    MIN_FREE_DECAY_S,
    MIN_PUSH_SNR,
    check_signal,
    excursion,
    free_decay_start,
    highpass,
    push_snr,
)

__all__ = [
    "GUARD_S",
    "SEGMENT_KINDS",
    "Segment",
    "Transient",
    "activity",
    "chosen_ring_down",
    "find_transients",
    "free_decay",
    "trial_segments",
]

#: the kinds of :class:`Segment`
SEGMENT_KINDS = ("rest", "transient", "push", "ring-down", "release")
#: the activity's high-pass [Hz]: below the slosh (≥ ~1.5 Hz in hand-held containers)
RISE_CUTOFF_HZ = 1.0
#: a transient: the activity rises above this many times its level over the window before
RISE_RATIO = 2.5
#: ... plus this many times the signal's noise level (the RMS of its quietest stretches)
RISE_NOISE = 4.0
#: the window before a sample that a rise is judged against [s]: about one slosh period
RISE_WINDOW_S = 0.6
#: ... ending this long before the sample [s]: the zero-phase filters smooth a step's rise
#: over about this long
RISE_LAG_S = 0.3
#: rises closer than this to the previous rise belong to one transient [s]
MERGE_S = 1.0
#: a transient's largest excursion (where a free decay would start) is sought this long [s]
PEAK_S = 1.0
#: a ring-down's window ends this long before the next transient's onset [s]: the
#: zero-phase filters spread a large step about this far back in time
GUARD_S = 0.3
#: a signal that begins inside a ring-down: its first samples are the filters' edge [s]
EDGE_S = 0.3

#: ``classify(t, u, start_s, end_s, closed) -> reason`` ("" for a ring-down)
Classifier = Callable[[np.ndarray, np.ndarray, float, float, bool], str]


@dataclass(frozen=True)
class Segment:
    """One stretch of a trial's signal, on the signal's clock [s].

    ``kind`` (:data:`SEGMENT_KINDS`): ``rest`` before any transient; ``transient`` a
    grasp, lift or any motion not followed by a free decay; ``push`` the transient a
    ring-down follows (its onset to its largest excursion); ``ring-down`` the free decay
    while the bottle is held still (from the push's largest excursion to ``GUARD_S``
    before the next transient, or to the signal's end); ``release`` a transient after a
    ring-down (the end of the hold, the lowering, the release). ``closed``: a later
    transient ended it (a ring-down's estimate is then final). ``event``: the protocol's
    name of a transient, when the events were given. ``reason``: why the stretch after
    a transient is not a ring-down.
    """

    kind: str
    start_s: float
    end_s: float
    closed: bool = True
    event: str = ""
    reason: str = ""

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s

    def to_dict(self) -> dict[str, object]:
        """JSON-ready: ``kind``, ``start_s``, ``end_s``, ``closed``, ``event``, ``reason``."""
        return {
            "kind": self.kind,
            "start_s": self.start_s,
            "end_s": self.end_s,
            "closed": self.closed,
            "event": self.event,
            "reason": self.reason,
        }


@dataclass(frozen=True)
class Transient:
    """A rise of the activity: ``onset_s`` (the first sample that rose), ``peak_s`` (its
    largest excursion within ``PEAK_S``, before the next transient), ``event`` (the
    protocol's name, when known)."""

    onset_s: float
    peak_s: float
    event: str = ""


def activity(t: np.ndarray, x: np.ndarray, cutoff_hz: float = RISE_CUTOFF_HZ) -> np.ndarray:
    """How far the signal is from rest at each sample: ``|x high-passed at cutoff_hz|``.

    ``x`` is ``(T,)`` (u) or ``(T, C)`` (channels, e.g. every chosen marker's x and y
    motion: a motion in any direction counts); the channels' norm is returned. The
    high-pass (zero-phase, 2nd order) at ``RISE_CUTOFF_HZ`` keeps the slosh and turns a
    step (a lift, a lowering) into a short bump: at ``DRIFT_CUTOFF_HZ`` a step's bump
    spreads over seconds and hides the push after a lift.
    """
    x = np.asarray(x, dtype=float)
    columns = x[:, None] if x.ndim == 1 else x.reshape(len(x), -1)
    rate_hz = 1.0 / float(np.median(np.diff(t)))
    if len(t) > 30 and rate_hz > 4 * cutoff_hz:
        columns = highpass(t, columns, cutoff_hz)
    else:
        columns = columns - np.median(columns, axis=0)
    return np.sqrt(np.sum(columns**2, axis=1))


def find_transients(t: np.ndarray, x: np.ndarray) -> list[Transient]:
    """The transients of a signal (module docstring, "Trial segments"): where activity rises.

    ``x``: ``(T,)`` or ``(T, C)`` as :func:`activity`.
    """
    t = check_times(t, "t")
    a = activity(t, x)
    dt = float(np.median(np.diff(t)))
    w = max(2, round(RISE_WINDOW_S / dt))
    lag = max(1, round(RISE_LAG_S / dt))
    if len(a) <= w + lag + 1:
        return []
    windows = np.lib.stride_tricks.sliding_window_view(a, w)  # windows[k] = a[k:k+w]
    noise = float(np.sqrt(np.mean(windows**2, axis=1)).min())
    before = windows[: len(a) - w - lag + 1].max(axis=1)  # a[k-w-lag+1 : k-lag+1] for k
    rising = a[w + lag - 1 :] > RISE_RATIO * before + RISE_NOISE * noise
    onsets: list[int] = []
    last = -math.inf
    for k in np.flatnonzero(rising) + w + lag - 1:
        if t[k] - last >= MERGE_S:
            onsets.append(int(k))
        last = t[k]
    e = _excursions(t, x)
    return [
        Transient(float(t[k]), _peak_s(t, e, t[k], t[k] + PEAK_S, _next(t, onsets, i)))
        for i, k in enumerate(onsets)
    ]


def _excursions(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The channels' norm of :func:`free_decay_start`'s excursion (0.3 Hz high-pass, minus
    the resting level): where a free decay starts, as offline."""
    x = np.asarray(x, dtype=float)
    columns = x[:, None] if x.ndim == 1 else x.reshape(len(x), -1)
    return np.sqrt(sum(excursion(t, c)[1] ** 2 for c in columns.T))


def _next(t: np.ndarray, onsets: list[int], i: int) -> float:
    return float(t[onsets[i + 1]]) if i + 1 < len(onsets) else math.inf


def _peak_s(t: np.ndarray, a: np.ndarray, lo: float, hi: float, before: float) -> float:
    inside = (t >= lo) & (t <= hi) & (t < before)
    if not inside.any():
        return float(lo)
    return float(t[np.flatnonzero(inside)[np.argmax(a[inside])]])


def _default_classifier(t: np.ndarray, u: np.ndarray) -> Classifier:
    def classify(tt: np.ndarray, uu: np.ndarray, start: float, end: float, closed: bool) -> str:
        keep = (tt >= start) & (tt <= end)
        return ring_down_reason(tt[keep], uu[keep])[0]

    return classify


def trial_segments(
    t: np.ndarray,
    x: np.ndarray,
    events: Mapping[str, float] | None = None,
    *,
    u: np.ndarray | None = None,
    classify: Classifier | None = None,
    final: bool = True,
) -> list[Segment]:
    """Split a trial's signal into rest, transients, push, ring-down, release (module docstring).

    ``t`` [s], ``x`` ``(T,)`` or ``(T, C)`` (the channels the transients are found on);
    ``u`` the 1-D signal the ring-downs are judged on (default ``x`` when 1-D, else its
    first channel). ``events``: the protocol's times on this clock [s] (``push``,
    ``pushed``, and the end of the hold: ``stopped``, ``lower`` or ``hold_end``; others
    such as ``grasp`` and ``lift`` name the transients at those times). ``classify``
    replaces :func:`ring_down_reason` (e.g. to cache verdicts while streaming). ``final``:
    the signal is complete (else the last candidate may still become a ring-down).
    """
    t = check_times(t, "t")
    x = np.asarray(x, dtype=float)
    if u is None:
        u = x if x.ndim == 1 else x.reshape(len(x), -1)[:, 0]
    u = finite_array(u, "u", min_ndim=1)
    classify = classify or _default_classifier(t, u)
    if events and "push" in events:
        return _known_segments(t, x, dict(events))
    transients = find_transients(t, x)
    t0, t_end = float(t[0]), float(t[-1])
    segments: list[Segment] = []
    first_end = transients[0].onset_s if transients else t_end
    closed = bool(transients)
    end = first_end - GUARD_S if closed else first_end
    start = t0 + EDGE_S
    # a stream that begins inside a ring-down: the free decay from its first trusted sample
    reason = classify(t, u, start, end, closed) if end - start >= MIN_CANDIDATE_S else "short"
    if reason and end - start >= MIN_CANDIDATE_S:
        # else from the stretch's largest excursion (a push not told apart), found on the
        # stretch's own signal (up to its end, every channel): over the whole stream the
        # high-pass spreads the lowering's step back into it and u's PCA is the lowering's
        upto = t <= end
        distance = _excursions(t[upto], x[upto])
        inside = t[upto] >= start
        peak = float(t[np.flatnonzero(inside)[np.argmax(distance[inside])]])
        if end - peak >= MIN_CANDIDATE_S and peak - start > EDGE_S:
            start = peak
            reason = classify(t, u, start, end, closed)
    if reason:
        segments.append(Segment("rest", t0, first_end, closed))
    else:
        segments.append(Segment("ring-down", start, end, closed))
    for i, tr in enumerate(transients):
        nxt = transients[i + 1].onset_s if i + 1 < len(transients) else math.inf
        closed = math.isfinite(nxt)
        end = nxt - GUARD_S if closed else t_end
        after_ring_down = any(s.kind == "ring-down" for s in segments)
        if end - tr.peak_s < MIN_CANDIDATE_S:
            reason = "too short to judge"
        else:
            reason = classify(t, u, tr.peak_s, end, closed)
        if reason:
            kind = "release" if after_ring_down else "transient"
            stop = nxt if closed else t_end
            segments.append(Segment(kind, tr.onset_s, stop, closed, reason=reason))
        else:
            segments.append(Segment("push", tr.onset_s, tr.peak_s, True))
            segments.append(Segment("ring-down", tr.peak_s, end, closed))
    return segments


def _known_segments(t: np.ndarray, x: np.ndarray, events: dict[str, float]) -> list[Segment]:
    """Segments from the protocol's events: the push and the end of the hold are known."""
    a = _excursions(t, x)
    t0, t_end = float(t[0]), float(t[-1])
    push, pushed = float(events["push"]), float(events.get("pushed", events["push"]))
    # the end of this push's hold: the first end event after it (an earlier push's hold
    # ended before it: run-trial --max-pushes gives several pushes, the latest is ``push``)
    hold_end = min(
        (
            float(events[k])
            for k in ("stopped", "hold_end", "lower")
            if k in events and float(events[k]) > push
        ),
        default=math.inf,
    )
    peak = _peak_s(t, a, max(push, t0), pushed + PEAK_S, hold_end)
    segments: list[Segment] = []
    before = sorted((v, k) for k, v in events.items() if v < push and k not in ("recording",))
    if t0 < push:
        edges = [t0] + [v for v, _ in before if v > t0] + [push]
        names = ["rest"] + [k for v, k in before if v > t0]
        for (lo, hi), name in zip(itertools.pairwise(edges), names, strict=True):
            if hi > lo:
                kind = "rest" if name == "rest" else "transient"
                segments.append(Segment(kind, lo, hi, True, event="" if kind == "rest" else name))
    segments.append(Segment("push", push, peak, True, event="push"))
    closed = hold_end <= t_end
    end = hold_end - GUARD_S if closed else t_end
    segments.append(Segment("ring-down", peak, end, closed, event="hold"))
    if closed:
        segments.append(Segment("release", hold_end, t_end, True, event="end of hold"))
    return segments


def chosen_ring_down(segments: list[Segment], min_s: float = MIN_FREE_DECAY_S) -> Segment | None:
    """The ring-down to report: the last one lasting at least ``min_s`` [s], else the longest."""
    rings = [s for s in segments if s.kind == "ring-down"]
    long_enough = [s for s in rings if s.duration_s >= min_s]
    if long_enough:
        return long_enough[-1]
    return max(rings, key=lambda s: s.duration_s, default=None)


def free_decay(
    t: np.ndarray, u: np.ndarray, events: Mapping[str, float] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """``(t, u)`` of the ring-down to fit; time is kept absolute [s].

    The ring-down of :func:`trial_segments` (:func:`chosen_ring_down`; ``events``: the
    protocol's times, when known): from the push's largest excursion to ``GUARD_S``
    before the end of the hold, or to the end of the signal. When no stretch qualifies
    as a ring-down, the largest excursion to the end, as before.

    Raises :class:`SignalError` for a malformed signal (see :func:`free_decay_start`)
    "no push found" when the largest excursion does not stand out of the noise before
    it (:func:`push_snr` below ``MIN_PUSH_SNR``), and "record longer after the push"
    when less than ``MIN_FREE_DECAY_S`` follows it.
    """
    t, u = check_signal(t, u)
    ring = chosen_ring_down(trial_segments(t, u, events)) if len(t) > 30 else None
    if ring is not None and ring.duration_s >= MIN_FREE_DECAY_S:
        keep = (t >= ring.start_s) & (t <= ring.end_s)
        return t[keep], u[keep]
    start = free_decay_start(t, u)
    # judged however long the rest is: a still recording's noise otherwise reaches the
    # fit, which calls it overdamped, whenever its largest excursion is early
    snr = push_snr(t, u, start)
    if snr < MIN_PUSH_SNR:
        raise SignalError(
            f"no push found: the largest excursion of u (at {t[start]:.2f} s) is only "
            f"{snr:.1f}× the noise level before it (a push stands out at least "
            f"{MIN_PUSH_SNR:g}×); was the container pushed, and do the videos show it?"
        )
    if t[-1] - t[start] < MIN_FREE_DECAY_S:
        raise SignalError(
            f"the free decay after the push lasts only {t[-1] - t[start]:.2g} s "
            f"(peak at {t[start]:.2f} s of {t[-1]:.2f} s); record at least "
            f"{MIN_FREE_DECAY_S:.0f} s after the push"
        )
    return t[start:], u[start:]
