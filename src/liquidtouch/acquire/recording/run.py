"""Record for a given time: :func:`record`, the convenience wrapper around
:class:`~liquidtouch.acquire.recording.recorder.Recorder` (see its module docstring).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from liquidtouch.acquire.recording.recorder import Recorder
from liquidtouch.acquire.recording.summary import RecordingSummary
from liquidtouch.errors import DeviceError

logger = logging.getLogger(__name__)

__all__ = ["record"]


def record(
    sources: Sequence[str],
    seconds: float | None,
    out_dir: str | Path,
    *,
    on_progress: Callable[[Recorder, float], None] | None = None,
    progress_interval_s: float = 0.25,
    extra_meta: dict[str, object] | None = None,
    **kwargs: object,
) -> RecordingSummary:
    """Record ``sources`` for ``seconds`` (``None``: until every source ends) into ``out_dir``.

    ``kwargs`` go to :class:`Recorder` (``names``, ``profile``, ``fmt``, ``labels``,
    ``grey``, ...). ``on_progress(recorder, elapsed_s)`` is called about every
    ``progress_interval_s`` seconds (``recorder.stats()`` has the live numbers).
    Returns the summary, with ``trial_dir`` set. On any error or Ctrl-C nothing is
    left in ``out_dir``.
    """
    if seconds is not None and not 0 < float(seconds) < math.inf:
        raise DeviceError(f"the recording length must be a positive number of seconds: {seconds}")
    with Recorder(sources, out_dir, **kwargs) as recorder:  # type: ignore[arg-type]
        recorder.start()
        start = time.monotonic()
        while True:
            elapsed = time.monotonic() - start
            if seconds is not None and elapsed >= seconds:
                break
            if recorder.ended:
                logger.info("every source has ended after %.2f s", elapsed)
                break
            recorder.check()
            if on_progress is not None:
                on_progress(recorder, elapsed)
            wait = progress_interval_s
            if seconds is not None:
                wait = min(wait, max(0.0, seconds - elapsed))
            time.sleep(wait)
        summary = recorder.stop()
        if on_progress is not None:
            on_progress(recorder, time.monotonic() - start)
        recorder.finish(extra_meta)
    return summary
