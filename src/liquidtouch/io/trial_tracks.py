"""Marker tracks stored in a trial directory (``tracks.npz``, ``meta.json`` ``tracks``).

A trial imported from GelSight marker CSVs (:mod:`liquidtouch.io.marker_csv`)
stores the :class:`~liquidtouch.tracking.tracks.MarkerTracks` of its sensors as
``tracks.npz`` (:data:`TRACKS_NAME`, listed in ``meta.json`` under ``tracks``);
:func:`stored_tracks` hands them to the extraction instead of tracking videos.

Formats: ``docs/formats.md`` ("Imported recordings").
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from liquidtouch._core.checks import check_times
from liquidtouch.errors import DatasetError, VideoError
from liquidtouch.io.dataset import META_NAME, read_trial_meta
from liquidtouch.tracking.clock import check_consistent
from liquidtouch.tracking.tracks import MarkerTracks, load_tracks

TRACKS_NAME = "tracks.npz"
"""File name of imported marker tracks in a trial directory (``meta.json`` ``tracks``)."""


def read_trial_tracks(trial_dir: str | os.PathLike[str], meta: object = None) -> list[MarkerTracks]:
    """The marker tracks a trial directory stores (``meta.json`` ``tracks``), validated.

    Raises :class:`~liquidtouch.errors.DatasetError` if the trial lists no tracks
    or the file is missing, damaged or inconsistent.
    """

    trial = Path(trial_dir)
    meta = read_trial_meta(trial) if meta is None else meta
    name = getattr(meta, "tracks", None)
    if not name:
        raise DatasetError(f"{trial} stores no marker tracks (meta.json has no 'tracks')")
    path = trial / name
    root = trial.resolve()
    if Path(name).is_absolute() or ".." in Path(name).parts or root not in path.resolve().parents:
        raise DatasetError(f"{trial}/meta.json: tracks {name!r} must stay inside the trial")
    if not path.is_file():
        raise DatasetError(f"{path} does not exist; the trial's meta.json lists it as its tracks")
    try:
        tracks = load_tracks(path)
    except (OSError, ValueError, KeyError, EOFError) as exc:
        raise DatasetError(f"{path} is not a readable tracks file: {exc}") from None
    if not tracks:
        raise DatasetError(f"{path} holds no sensors")
    for tr in tracks:
        _check_tracks(tr, path)
    return tracks


def _check_tracks(tr: MarkerTracks, path: Path) -> None:
    t = np.asarray(tr.t, dtype=float)
    n_frames = t.shape[0] if t.ndim == 1 else -1
    n = tr.reference.shape[0] if tr.reference.ndim == 2 else -1
    shapes_ok = (
        t.ndim == 1
        and n_frames >= 2
        and n >= 2
        and tr.reference.shape == (n, 2)
        and tr.positions.shape == (n_frames, n, 2)
        and tr.valid.shape == (n_frames, n)
        and tr.valid.dtype == bool
    )
    if not shapes_ok:
        raise DatasetError(
            f"{path}: the arrays of sensor {tr.sensor!r} do not fit together (t {t.shape}, "
            f"positions {tr.positions.shape}, valid {tr.valid.shape}, reference "
            f"{tr.reference.shape}); expected (T,), (T, N, 2), (T, N), (N, 2) with T, N >= 2"
        )
    check_times(t, f"{path}: the times of sensor {tr.sensor!r}", DatasetError)
    if not np.isfinite(tr.reference).all():
        raise DatasetError(f"{path}: the reference of sensor {tr.sensor!r} holds NaN")
    if not np.isfinite(tr.positions[tr.valid]).all():
        raise DatasetError(f"{path}: sensor {tr.sensor!r} has valid positions that are NaN")


def stored_tracks(
    paths: object, sensors: Sequence[str] | str | None = None
) -> list[MarkerTracks] | None:
    """The stored marker tracks when ``paths`` is one trial directory that has them, else None.

    The extraction's hook: such a trial (imported from marker CSVs) is read from
    its ``tracks.npz`` instead of tracking videos. ``sensors`` selects sensors by
    name (:class:`~liquidtouch.errors.VideoError` for unknown ones).
    """

    items = [paths] if isinstance(paths, str | os.PathLike) else list(paths)  # type: ignore[call-overload]
    if len(items) != 1 or not isinstance(items[0], str | os.PathLike):
        return None
    trial = Path(items[0])
    if not (trial.is_dir() and (trial / META_NAME).is_file()):
        return None
    meta = read_trial_meta(trial)
    if not getattr(meta, "tracks", None):
        return None
    tracks = read_trial_tracks(trial, meta)
    if sensors is not None:
        wanted = [sensors] if isinstance(sensors, str) else list(sensors)
        names = [tr.sensor for tr in tracks]
        unknown = [s for s in wanted if s not in names]
        if unknown or not wanted:
            raise VideoError(
                f"no sensor {', '.join(map(repr, unknown)) or '(none given)'}; "
                f"the sensors are {', '.join(names)}"
            )
        tracks = [tr for tr in tracks if tr.sensor in set(wanted)]

    check_consistent(tracks)
    return tracks
