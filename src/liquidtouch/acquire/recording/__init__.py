"""Recording: GelSight cameras into a trial directory, losslessly, every frame timestamped.

Takes camera sources (:func:`liquidtouch.acquire.cameras.open_camera`), sensor names,
a format and labels; gives a trial directory (videos or PNG folders, per-frame
timestamps, meta.json written last) and a :class:`RecordingSummary` (frames, measured
rates, drops, duplicates, backlog drops). On any error or Ctrl-C nothing is left.

The modules: :mod:`~.recorder` (:class:`Recorder`: the lifecycle and the layout of the
trial), :mod:`~.run` (:func:`record`: record for a given time), :mod:`~.frame_writers`
(FFV1 and PNG writers), :mod:`~.writer_pool` (one encoder thread per sensor, bounded
backlog), :mod:`~.summary` (what a recording produced) and :mod:`~.meta` (its meta.json).
"""

from liquidtouch.acquire.recording.frame_writers import (
    FFV1_OPTIONS,
    PNG_COMPRESSION,
    PTS_RATE_HZ,
    VIDEO_SUFFIX,
    Ffv1Writer,
    FrameWriter,
    PngWriter,
)
from liquidtouch.acquire.recording.meta import RESERVED_META, build_meta
from liquidtouch.acquire.recording.recorder import FORMATS, Recorder
from liquidtouch.acquire.recording.run import record
from liquidtouch.acquire.recording.summary import RecordingSummary, SensorSummary
from liquidtouch.acquire.recording.writer_pool import MAX_BACKLOG_S, WRITER_FINISH_S

__all__ = [
    "FFV1_OPTIONS",
    "FORMATS",
    "MAX_BACKLOG_S",
    "PNG_COMPRESSION",
    "PTS_RATE_HZ",
    "RESERVED_META",
    "VIDEO_SUFFIX",
    "WRITER_FINISH_S",
    "Ffv1Writer",
    "FrameWriter",
    "PngWriter",
    "Recorder",
    "RecordingSummary",
    "SensorSummary",
    "build_meta",
    "record",
]
