"""The ring-down: where in a trial's signal the free decay is.

``start`` finds where the free decay starts after a push, ``segments`` splits a whole
trial (rest, push, ring-down, release) into :class:`Segment` s and picks the ring-down,
``check`` says whether a stretch is a ring-down at all. This face is what the stages
above (extraction, live) use.
"""

from __future__ import annotations

from liquidtouch._core.lazy import lazy_exports

__all__ = [
    "GUARD_S",
    "MIN_FREE_DECAY_S",
    "Segment",
    "chosen_ring_down",
    "free_decay",
    "free_decay_start",
    "ring_down_reason",
    "trial_segments",
]

_LAZY = {
    "GUARD_S": "liquidtouch.ring_down.segments",
    "MIN_FREE_DECAY_S": "liquidtouch.ring_down.start",
    "Segment": "liquidtouch.ring_down.segments",
    "chosen_ring_down": "liquidtouch.ring_down.segments",
    "free_decay": "liquidtouch.ring_down.segments",
    "free_decay_start": "liquidtouch.ring_down.start",
    "ring_down_reason": "liquidtouch.ring_down.check",
    "trial_segments": "liquidtouch.ring_down.segments",
}


# lazy (PEP 562), so that importing one module of the stage (the command line reads its
# defaults) does not import the rest of it, nor SciPy, OpenCV or PyAV
__getattr__ = lazy_exports(__name__, _LAZY)
