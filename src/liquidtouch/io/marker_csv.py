"""GelSight marker-location CSVs → :class:`~liquidtouch.tracking.tracks.MarkerTracks`.

:func:`read_marker_csv` reads the marker locations the GelSight SDK's
marker-tracking demo writes (``gsrobotics``, ``marker_locations_<n>.csv``): no
header, one row per marker per frame, ``frame, row, col, x0, y0, x, y`` — the
frame number (from 1), the marker's (row, column) in the printed grid, its
initial and its current position [px]. A file with a header row may name its
columns instead (``frame,row,col,x,y`` required; ``x0,y0`` and ``t_s`` optional;
the SDK's ``Ox,Oy,Cx,Cy`` are accepted for ``x0,y0,x,y``). Frames are timed by
the ``t_s`` column [s] if there is one, else by the frame rate the caller gives
(frame numbers that skip are dropped frames). A trial stores the imported tracks
as ``tracks.npz`` (:mod:`liquidtouch.io.trial_tracks`).

Formats: ``docs/formats.md`` ("Imported recordings").
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from liquidtouch._core.checks import (
    MAX_ABS_POSITION_PX,
    MAX_RATE_HZ,
    check_magnitude,
    check_times,
)
from liquidtouch.errors import TableError
from liquidtouch.io.signal_csv import check_csv_bounds, shorten
from liquidtouch.tracking.track import marker_spacing
from liquidtouch.tracking.tracks import MarkerTracks

MARKER_CSV_COLUMNS = ("frame", "row", "col", "x0", "y0", "x", "y")
"""The columns of a headerless GelSight marker CSV, in order."""
_REQUIRED = ("frame", "row", "col", "x", "y")
_ALIASES = {"ox": "x0", "oy": "y0", "cx": "x", "cy": "y", "column": "col"}
#: frame times of one frame (``t_s`` of its rows) may differ by this much [s]
_TIME_TOLERANCE_S = 1e-6


def read_marker_csv(
    path: str | os.PathLike[str], *, fps: float | None = None, sensor: str | None = None
) -> MarkerTracks:
    """Read a GelSight marker-location CSV into :class:`MarkerTracks` (see the module doc).

    ``fps`` [Hz] times the frames (frame ``k`` at ``(k - first) / fps``) when the
    file has no ``t_s`` column; a ``t_s`` column wins over ``fps``. ``sensor``
    names the tracks (default: the file's stem). Markers are ordered by (row,
    col); a marker missing from a frame, or with an empty or NaN ``x``/``y``,
    is lost there (``valid`` False). The reference positions are ``x0, y0``
    (the SDK's initial positions), else each marker's first position. Raises
    :class:`~liquidtouch.errors.TableError` for a file that is not such a CSV.
    """

    path = Path(path)
    if not path.is_file():
        raise TableError(f"marker CSV {path} does not exist")
    name = sensor if sensor is not None else (path.stem or "sensor")
    if fps is not None and not 0 < _number(fps) <= MAX_RATE_HZ:
        raise TableError(
            f"the frame rate (`fps`) must be a positive number in Hz up to {MAX_RATE_HZ:g}, "
            f"got {shorten(repr(fps), 40)}"
        )
    check_csv_bounds(path, "marker CSV")
    columns, table = _read_marker_table(path)
    where = shorten(path)
    frame = _integer_column(table, "frame", where)
    row = _integer_column(table, "row", where)
    col = _integer_column(table, "col", where)
    xy = np.column_stack([_float_column(table, c, where) for c in ("x", "y")])
    check_magnitude(xy, f"{where}: columns x, y", MAX_ABS_POSITION_PX, "px")
    if (frame < 0).any():
        raise TableError(f"{where}: frame numbers must be >= 0")
    frames, frame_idx = np.unique(frame, return_inverse=True)
    cells, marker_idx = np.unique(np.column_stack([row, col]), axis=0, return_inverse=True)
    marker_idx = marker_idx.ravel()
    n_frames, n_markers = len(frames), len(cells)
    if n_frames < 2:
        raise TableError(f"{where} holds {n_frames} frame(s); a recording needs many frames")
    flat = frame_idx * n_markers + marker_idx
    counts = np.bincount(flat, minlength=n_frames * n_markers)
    if (counts > 1).any():
        k = int(np.argmax(counts > 1))
        r, c = cells[k % n_markers]
        raise TableError(
            f"{where}: marker (row {r}, col {c}) appears twice in frame {frames[k // n_markers]}; "
            "give one row per marker per frame"
        )
    positions = np.full((n_frames, n_markers, 2), np.nan)
    positions[frame_idx, marker_idx] = xy
    valid = np.isfinite(positions).all(axis=2)
    keep = valid.any(axis=0)
    if keep.sum() < 2:
        raise TableError(f"{where} holds fewer than 2 markers with a position")
    reference = _reference(table, columns, frame, marker_idx, n_markers, positions, valid, where)
    positions, valid, reference = positions[:, keep], valid[:, keep], reference[keep]
    positions[~valid] = np.nan
    t = _frame_times(table, columns, frames, frame_idx, fps, where)
    return MarkerTracks(
        t=t,
        positions=positions,
        valid=valid,
        reference=reference,
        sensor=name,
        spacing_px=marker_spacing(reference),
    )


def _number(value: object) -> float:
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return math.nan


def _read_marker_table(path: Path) -> tuple[list[str], dict[str, np.ndarray]]:
    """Column names and the raw (stripped string) columns of a marker CSV."""
    import pandas as pd

    try:
        with path.open(encoding="utf-8") as handle:
            first = next((line for line in handle if line.strip()), "")
    except UnicodeDecodeError:
        raise TableError(f"{shorten(path)} is not a text CSV file") from None
    if not first:
        raise TableError(
            f"{shorten(path)} is empty; expected rows of {', '.join(MARKER_CSV_COLUMNS)}"
        )
    fields = [cell.strip() for cell in first.split(",")]
    headerless = all(
        cell.lower() in ("", "nan") or not math.isnan(_number(cell)) for cell in fields
    )
    if headerless and len(fields) != len(MARKER_CSV_COLUMNS):
        raise TableError(
            f"{shorten(path)}: a marker CSV without a header has {len(MARKER_CSV_COLUMNS)} "
            f"columns ({', '.join(MARKER_CSV_COLUMNS)}, as the GelSight SDK writes them); this "
            f"one has {len(fields)}. Add a header row naming the columns "
            "(frame,row,col,x,y and optionally x0,y0,t_s)"
        )
    try:
        frame = pd.read_csv(
            path,
            header=None if headerless else 0,
            names=list(MARKER_CSV_COLUMNS) if headerless else None,
            dtype=str,
            keep_default_na=False,
            na_filter=False,
            skipinitialspace=True,
            skip_blank_lines=True,
        )
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise TableError(f"{shorten(path)} is not a readable CSV: {shorten(exc)}") from None
    names = [_ALIASES.get(str(c).strip().lower(), str(c).strip().lower()) for c in frame.columns]
    missing = [c for c in _REQUIRED if c not in names]
    if missing:
        raise TableError(
            f"{shorten(path)} lacks column(s) {', '.join(missing)}; a marker CSV has the columns "
            "frame,row,col,x,y (and optionally x0,y0,t_s), or no header and the GelSight SDK's "
            "7 columns frame, row, col, x0, y0, x, y"
        )
    if len(set(names)) < len(names):
        raise TableError(f"{shorten(path)} names a column twice: {', '.join(names)}")
    if frame.empty:
        raise TableError(f"{shorten(path)} holds no rows")
    table = {name: frame.iloc[:, k].str.strip().to_numpy(dtype=str) for k, name in enumerate(names)}
    return names, table


def _as_floats(values: np.ndarray, name: str, where: str, *, allow_missing: bool) -> np.ndarray:
    import pandas as pd

    out = pd.to_numeric(pd.Series(values), errors="coerce").to_numpy(float)
    missing = np.char.lower(values.astype(str)) == "nan"
    missing |= values == ""
    bad = np.isnan(out) & ~missing if allow_missing else ~np.isfinite(out)
    bad |= np.isinf(out)
    if bad.any():
        k = int(np.argmax(bad))

        raise TableError(
            f"{where}: column {name} must hold numbers; data row {k + 1} has {shorten(values[k])!r}"
        )
    return out


def _integer_column(table: dict[str, np.ndarray], name: str, where: str) -> np.ndarray:
    values = _as_floats(table[name], name, where, allow_missing=False)
    if (values != np.round(values)).any() or (np.abs(values) > 2**53).any():
        k = int(np.argmax(values != np.round(values)))
        raise TableError(f"{where}: column {name} must hold whole numbers; row {k + 1} is not")
    return values.astype(np.int64)


def _float_column(table: dict[str, np.ndarray], name: str, where: str) -> np.ndarray:
    return _as_floats(table[name], name, where, allow_missing=True)


def _reference(
    table: dict[str, np.ndarray],
    columns: list[str],
    frame: np.ndarray,
    marker_idx: np.ndarray,
    n_markers: int,
    positions: np.ndarray,
    valid: np.ndarray,
    where: str,
) -> np.ndarray:
    """(N, 2) reference positions: x0, y0 of each marker's earliest row, else its first position."""
    first_valid = np.argmax(valid, axis=0)
    reference = positions[first_valid, np.arange(n_markers)]
    if "x0" in columns and "y0" in columns:
        start = np.column_stack([_float_column(table, c, where) for c in ("x0", "y0")])
        check_magnitude(start, f"{where}: columns x0, y0", MAX_ABS_POSITION_PX, "px")
        order = np.argsort(frame, kind="stable")
        _, first_row = np.unique(marker_idx[order], return_index=True)
        rows = order[first_row]
        given = np.full((n_markers, 2), np.nan)
        given[marker_idx[rows]] = start[rows]
        ok = np.isfinite(given).all(axis=1)
        reference[ok] = given[ok]
    return reference


def _frame_times(
    table: dict[str, np.ndarray],
    columns: list[str],
    frames: np.ndarray,
    frame_idx: np.ndarray,
    fps: float | None,
    where: str,
) -> np.ndarray:
    """Frame times [s] from 0: the ``t_s`` column, else the frame numbers over ``fps``."""
    if "t_s" in columns:
        stamps = _as_floats(table["t_s"], "t_s", where, allow_missing=False)
        low = np.full(len(frames), np.inf)
        high = np.full(len(frames), -np.inf)
        np.minimum.at(low, frame_idx, stamps)
        np.maximum.at(high, frame_idx, stamps)
        if (high - low > _TIME_TOLERANCE_S).any():
            k = int(np.argmax(high - low > _TIME_TOLERANCE_S))
            raise TableError(
                f"{where}: the rows of frame {frames[k]} have different t_s ({low[k]:g} to "
                f"{high[k]:g} s); every row of a frame needs the frame's time"
            )
        check_times(low, f"{where}: column t_s (by frame number)", TableError, min_count=1)
        return low - low[0]
    if fps is None:
        raise TableError(
            f"{where} has no t_s column, so its frames need a frame rate: pass `fps` (the "
            "camera's frame rate), or add a t_s column (frame time in seconds) to the file"
        )
    return (frames - frames[0]) / float(fps)
