"""How long a camera may take: the default deadlines of the lab path [s].

Each deadline bounds a whole call (not each network read): opening a stream,
the warm-up after opening (its first frame included), and each frame. They are
defaults of the camera classes, the recorder and the ``--open-timeout``,
``--read-timeout`` and ``--warmup-timeout`` options; the range they may take is
:data:`liquidtouch._core.checks.MAX_TIMEOUT_S`. No imports: the command line reads
them at start-up.
"""

__all__ = [
    "DEFAULT_OPEN_TIMEOUT_S",
    "DEFAULT_READ_TIMEOUT_S",
    "DEFAULT_WARMUP_TIMEOUT_S",
    "TRIAL_READ_TIMEOUT_S",
]

DEFAULT_OPEN_TIMEOUT_S = 5.0
"""How long opening a network stream may take, as a whole (connect, request, headers) [s]."""
DEFAULT_READ_TIMEOUT_S = 2.0
"""How long a camera may take, as a whole, to deliver one frame [s] before it fails."""
DEFAULT_WARMUP_TIMEOUT_S = 5.0
"""How long the whole warm-up after opening (its first frame included) may take [s]."""
TRIAL_READ_TIMEOUT_S = 10.0
"""The frame deadline of ``run-trial`` [s]: generous, so that a loaded two-core machine
(the rig, ``live`` and a browser sharing it) does not abort a trial on a camera that is
only late (2 of 7 runs failed at 2 s)."""
