"""Where the free decay starts: the fit covers the sloshing after the push, not the push.

During the push the hand drives the liquid, so the signal there does not follow
the free damped-oscillation model (and a fit across it finds no oscillation).
The free decay starts at the largest excursion of the signal from its
pre-push level: after that peak the hand is still and the liquid rings down.
Slow in-hand slip adds a drift that can end further from the resting level
than the push went (a viscous liquid rings down in a second), so the
excursion is measured on the signal with its slow part removed: a zero-phase
high-pass well below any hand-held slosh (≥ ~1 Hz for containers up to ~30 cm
long), above the drift.

When the free decay after that peak is too short to fit, the peak is first
checked against the noise: a push stands out of the signal before it
(:func:`push_snr`: the peak's distance from the median of the high-passed
signal up to ``PUSH_GAP_S`` before it, over that signal's robust noise level,
1.4826 × MAD). Below :data:`MIN_PUSH_SNR` the largest excursion is just the
noise of a still recording, and the error says "no push found" instead of
asking for a longer recording. Measured: on 32 simulated trials (water, sugar
water, mirin, olive and corn oil, detergent; both sensor profiles; ~1 s of
signal before the push) a push stands 26–64× above the noise before it; on
low-passed (3 Hz) white noise (400 draws each at 25–100 fps, 4–60 s) the
largest excursion reaches at most 10.5× (filter edge effects), a still
simulated GelSight video 4.8×.

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
   oscillation in the slosh band (:func:`ring_down_reason`: the single-mode fit finds an
   oscillation above the noise, ω ≥ ``MIN_OMEGA_OVER_LAMBDA`` λ, and ``MIN_LOBES``
   half-cycles stand above ``LOBE_FRACTION`` of its peak) — not "the largest excursion".
   The transient it follows is the **push**; a transient after a ring-down is a
   **release**; the others are **transients** (grasp, lift).
3. **A signal that begins inside a ring-down** (a camera started late, a recording cut
   after the push) is a ring-down from its first samples (after the filters' edge,
   ``EDGE_S``) when that stretch is a decaying oscillation.
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
from scipy.signal import butter, sosfiltfilt

from liquidtouch._core.checks import as_number
from liquidtouch.clock import check_times, finite_array
from liquidtouch.errors import LiquidTouchError, NoOscillationError, SignalError
from liquidtouch.fit.oscillation import GAP_STEPS, fit_oscillation

__all__ = [
    "DRIFT_CUTOFF_HZ",
    "GUARD_S",
    "MIN_FREE_DECAY_S",
    "MIN_NOISE_S",
    "MIN_PUSH_SNR",
    "PUSH_GAP_S",
    "SEGMENT_KINDS",
    "Segment",
    "Transient",
    "activity",
    "chosen_ring_down",
    "find_transients",
    "free_decay",
    "free_decay_start",
    "highpass",
    "push_snr",
    "ring_down_reason",
    "trial_segments",
]

MIN_FREE_DECAY_S = 2.0
DRIFT_CUTOFF_HZ = 0.3  # slower than this is slip drift, not slosh
#: a push's excursion stands at least this many noise levels above the signal before it
MIN_PUSH_SNR = 15.0
PUSH_GAP_S = 0.5  # the push itself: left out of the noise level before the peak
MIN_NOISE_S = 2.0  # less signal before the peak: its noise level is not judged


def free_decay_start(
    t: np.ndarray, u: np.ndarray, baseline_s: float = 0.3, drift_cutoff_hz: float = DRIFT_CUTOFF_HZ
) -> int:
    """Index of the sample where the free decay starts (the largest excursion).

    ``t`` [s] (finite, strictly increasing) and ``u`` are 1-D of one length.
    ``baseline_s`` [s] of the start of the recording set the resting level;
    motion slower than ``drift_cutoff_hz`` [Hz] (slip drift) is ignored.
    """
    t, u = _check_signal(t, u)
    return _excursion(t, u, baseline_s, drift_cutoff_hz)[0]


def highpass(t: np.ndarray, x: np.ndarray, cutoff_hz: float) -> np.ndarray:
    """Zero-phase 2nd-order high-pass of ``x`` [(T,) or (T, C)] at ``cutoff_hz`` [Hz].

    ``t`` [s] may have gaps (samples never observed, longer than ``GAP_STEPS`` median
    steps): the filter then runs on a uniform grid through them and is read back at the
    observed samples only.
    """
    step = float(np.median(np.diff(t)))
    sos = butter(2, cutoff_hz, btype="highpass", fs=1.0 / step, output="sos")
    if np.diff(t).max() <= GAP_STEPS * step:
        return sosfiltfilt(sos, x, axis=0)
    grid = t[0] + step * np.arange(int(np.floor((t[-1] - t[0]) / step)) + 1)
    columns = x[:, None] if x.ndim == 1 else x
    filled = np.column_stack([np.interp(grid, t, c) for c in columns.T])
    back = np.column_stack([np.interp(t, grid, c) for c in sosfiltfilt(sos, filled, axis=0).T])
    return back[:, 0] if x.ndim == 1 else back


def _excursion(
    t: np.ndarray,
    u: np.ndarray,
    baseline_s: float = 0.3,
    drift_cutoff_hz: float = DRIFT_CUTOFF_HZ,
) -> tuple[int, np.ndarray]:
    """Index of the largest excursion and the high-passed signal minus its resting level."""

    if not 0 <= as_number(baseline_s) < math.inf:
        raise SignalError(f"baseline_s must be a duration >= 0 in seconds, got {baseline_s!r}")
    if not 0 < as_number(drift_cutoff_hz) < math.inf:
        raise SignalError(
            f"drift_cutoff_hz must be a frequency > 0 in Hz, got {drift_cutoff_hz!r}; "
            f"the default is {DRIFT_CUTOFF_HZ}"
        )
    if len(u) > 30 and 1.0 / float(np.median(np.diff(t))) > 4 * drift_cutoff_hz:
        u = highpass(t, u, drift_cutoff_hz)
    resting = float(np.median(u[t <= t[0] + baseline_s]))
    excursion = np.abs(u - resting)
    return int(np.argmax(excursion)), u - resting


def push_snr(
    t: np.ndarray, u: np.ndarray, start: int | None = None, *, min_noise_s: float = MIN_NOISE_S
) -> float:
    """How far the largest excursion stands above the noise before it (module docstring).

    With ``b`` the high-passed signal up to ``PUSH_GAP_S`` before the peak, returns
    ``|peak − median(b)| / (1.4826 × MAD(b))``; NaN when ``b`` spans less than
    ``min_noise_s`` [s] (default ``MIN_NOISE_S``; the streaming estimator judges a
    push on less), inf when its samples are all equal.
    """
    t, u = _check_signal(t, u)
    peak, centred = _excursion(t, u)
    peak = peak if start is None else int(start)
    quiet = t < t[peak] - PUSH_GAP_S
    if not quiet.any() or t[quiet][-1] - t[0] < min_noise_s:
        return math.nan
    before = centred[quiet]
    level = float(np.median(before))
    noise = 1.4826 * float(np.median(np.abs(before - level)))
    return abs(float(centred[peak]) - level) / noise if noise > 0 else math.inf


def free_decay(
    t: np.ndarray, u: np.ndarray, events: Mapping[str, float] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """``(t, u)`` of the ring-down to fit; time is kept absolute [s].

    The ring-down of :func:`trial_segments` (:func:`chosen_ring_down`; ``events``: the
    protocol's times, when known): from the push's largest excursion to ``GUARD_S``
    before the end of the hold, or to the end of the signal. When no stretch qualifies
    as a ring-down, the largest excursion to the end, as before.

    Raises :class:`SignalError` for a malformed signal (see :func:`free_decay_start`)
    or when less than ``MIN_FREE_DECAY_S`` follows the largest excursion: "no push
    found" when that excursion does not stand out of the noise before it
    (:func:`push_snr` below ``MIN_PUSH_SNR``), else "record longer after the push".
    """
    t, u = _check_signal(t, u)
    ring = chosen_ring_down(trial_segments(t, u, events)) if len(t) > 30 else None
    if ring is not None and ring.duration_s >= MIN_FREE_DECAY_S:
        keep = (t >= ring.start_s) & (t <= ring.end_s)
        return t[keep], u[keep]
    start = free_decay_start(t, u)
    if t[-1] - t[start] < MIN_FREE_DECAY_S:
        snr = push_snr(t, u, start)
        if snr < MIN_PUSH_SNR:
            raise SignalError(
                f"no push found: the largest excursion of u (at {t[start]:.2f} s) is only "
                f"{snr:.1f}× the noise level before it (a push stands out at least "
                f"{MIN_PUSH_SNR:g}×); was the container pushed, and do the videos show it?"
            )
        raise SignalError(
            f"the free decay after the push lasts only {t[-1] - t[start]:.2g} s "
            f"(peak at {t[start]:.2f} s of {t[-1]:.2f} s); record at least "
            f"{MIN_FREE_DECAY_S:.0f} s after the push"
        )
    return t[start:], u[start:]


# -- the trial's events: rest, transients, the push, the ring-down, the end of the hold -----

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
#: a ring-down oscillates: its fitted ω is at least this many times λ (the catalogue's most
#: damped liquid, detergent, has ω/λ ≈ 4; the lowering and release taken for a push fitted
#: λ 6.8, ω 14: ω/λ ≈ 2)
MIN_OMEGA_OVER_LAMBDA = 3.0
#: ... and shows at least this many half-cycles above LOBE_FRACTION of its largest one
MIN_LOBES = 3
LOBE_FRACTION = 0.05
#: least candidate judged [s]: shorter, it is not (yet) a ring-down
MIN_CANDIDATE_S = 0.5

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
    return np.sqrt(sum(_excursion(t, c)[1] ** 2 for c in columns.T))


def _next(t: np.ndarray, onsets: list[int], i: int) -> float:
    return float(t[onsets[i + 1]]) if i + 1 < len(onsets) else math.inf


def _peak_s(t: np.ndarray, a: np.ndarray, lo: float, hi: float, before: float) -> float:
    inside = (t >= lo) & (t <= hi) & (t < before)
    if not inside.any():
        return float(lo)
    return float(t[np.flatnonzero(inside)[np.argmax(a[inside])]])


def ring_down_reason(t: np.ndarray, u: np.ndarray) -> tuple[str, object | None]:
    """Whether ``(t, u)`` is a free decay: ``("", fit)``, else ``(why not, fit or None)``.

    A ring-down is a decaying oscillation in the slosh band: the single-mode fit
    (least squares, as a quick check) finds an oscillation above the noise that is not
    overdamped (``fit_oscillation``'s own check), with ω ≥ ``MIN_OMEGA_OVER_LAMBDA`` λ,
    and at least ``MIN_LOBES`` half-cycles (between zero crossings of the detrended
    signal) reach ``LOBE_FRACTION`` of the largest.
    """
    if len(t) < 8 or t[-1] - t[0] < MIN_CANDIDATE_S:
        return "too short to judge", None
    try:
        fit = fit_oscillation(t, u, model="single-mode", loss="ls", min_duration_s=MIN_CANDIDATE_S)
    except NoOscillationError as exc:
        return str(exc), None
    except LiquidTouchError as exc:
        return str(exc), None
    if fit.angular_frequency < MIN_OMEGA_OVER_LAMBDA * fit.decay_rate:
        return (
            f"not a free decay: λ {fit.decay_rate:.3g}/s, ω {fit.angular_frequency:.3g} rad/s "
            f"(a ring-down has ω ≥ {MIN_OMEGA_OVER_LAMBDA:g} λ)"
        ), fit
    x = (t - t[0]) / max(t[-1] - t[0], 1e-12)
    design = np.vander(x, 3)
    detrended = u - design @ np.linalg.lstsq(design, u, rcond=None)[0]
    crossings = np.flatnonzero(np.signbit(detrended[1:]) != np.signbit(detrended[:-1])) + 1
    lobes = [np.max(np.abs(p)) for p in np.split(detrended, crossings) if len(p)]
    big = max(lobes, default=0.0)
    if sum(lobe >= LOBE_FRACTION * big for lobe in lobes) < MIN_LOBES:
        return f"not a free decay: fewer than {MIN_LOBES} half-cycles", fit
    return "", fit


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
    if end - start >= MIN_CANDIDATE_S:  # from its largest excursion (a push not told apart)
        inside = (t >= start) & (t <= end)
        excursion = np.abs(_excursion(t, u)[1])
        start = float(t[np.flatnonzero(inside)[np.argmax(excursion[inside])]])
    reason = classify(t, u, start, end, closed) if end - start >= MIN_CANDIDATE_S else "short"
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
    hold_end = min(
        (float(events[k]) for k in ("stopped", "hold_end", "lower") if k in events),
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


def _check_signal(t: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t = check_times(t, "t")
    u = finite_array(u, "u", min_ndim=1)
    if u.shape != t.shape:
        raise SignalError(
            f"t and u must be 1-D arrays of equal length (got shapes {t.shape} and {u.shape})"
        )
    return t, u
