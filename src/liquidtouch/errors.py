"""Typed exceptions of liquidtouch.

Every error a user can cause with bad input is a :class:`LiquidTouchError`;
the command line turns it into one line ``error: <message>`` on stderr and
exit status 2. Messages say what is wrong and what to do about it.
"""

from __future__ import annotations

__all__ = [
    "CatalogueError",
    "DatasetError",
    "DeviceError",
    "LiquidTouchError",
    "MarkerError",
    "ModelFileError",
    "NoOscillationError",
    "OutputError",
    "SignalError",
    "SwallowedRingDownError",
    "TableError",
    "VideoError",
]


class LiquidTouchError(ValueError):
    """Base class of all input errors raised by liquidtouch."""


class SignalError(LiquidTouchError):
    """A signal is unusable: too short, non-finite, flat, or without oscillation."""


class NoOscillationError(SignalError):
    """The signal holds no damped oscillation (overdamped, or noise only)."""


class SwallowedRingDownError(NoOscillationError):
    """No oscillation was found after the push, and a gap without samples lies where the
    ring-down should be: a camera stall may have swallowed it."""


class VideoError(LiquidTouchError):
    """A video or image source cannot be read, or the sources of one trial disagree."""


class MarkerError(LiquidTouchError):
    """No markers, too few markers, or all markers lost."""


class TableError(LiquidTouchError):
    """A CSV table has missing or wrong columns, or bad values."""


class ModelFileError(LiquidTouchError):
    """A model file is not ours, is corrupt, or is of a newer format version."""


class DatasetError(LiquidTouchError):
    """A trial or dataset directory is malformed."""


class OutputError(LiquidTouchError):
    """An output path cannot be written (a directory, a read-only place, a full disk)."""


class CatalogueError(LiquidTouchError):
    """An unknown liquid, container, preset or sensor name."""


class DeviceError(LiquidTouchError):
    """A camera, gripper or arm cannot be reached or misbehaves."""
