"""A dataset directory made by hand: its marker file, the ``add`` lock, the manifest's rows.

**Empty datasets.** ``manifest.csv`` must list at least one trial, so a new
dataset (:func:`init_dataset`) holds only the marker file ``.liquidtouch-dataset``
(JSON); the first trial added writes ``manifest.csv``. :func:`is_dataset` accepts
a directory with the marker or with a ``manifest.csv`` (e.g. a simulated dataset).

**Appending.** :func:`append_manifest_row` reads the manifest, appends one row and
rewrites it atomically; existing rows are kept byte for byte. Concurrent writers
are serialised by :func:`dataset_lock` on the marker file.
"""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Iterator
from pathlib import Path

from liquidtouch._core import atomic
from liquidtouch.errors import DatasetError
from liquidtouch.io.dataset import MANIFEST_NAME, read_manifest

DATASET_MARKER = ".liquidtouch-dataset"
"""Marker file of a dataset directory made by :func:`init_dataset` (also the ``add`` lock)."""
DATASET_FORMAT = {"format": "liquidtouch-dataset", "format_version": 1}


def init_dataset(root: str | os.PathLike[str]) -> Path:
    """Create the empty dataset directory ``root`` (new, or an existing empty directory).

    Writes only the marker file :data:`DATASET_MARKER`; adding the first trial
    (:func:`~liquidtouch.io.recordings.add_trial`) writes ``manifest.csv``. Raises
    :class:`DatasetError` if ``root`` is already a dataset, a file, or a directory
    holding other files.
    """
    root = Path(root)
    if is_dataset(root):
        raise DatasetError(f"{root} is already a dataset directory; add trials to it")
    if root.exists() and not root.is_dir():
        raise DatasetError(f"{root} exists and is not a directory")
    if root.is_dir() and any(root.iterdir()):
        raise DatasetError(
            f"{root} is not empty; give a new or empty directory for the dataset (the "
            "recordings to add can stay where they are)"
        )
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise DatasetError(f"cannot create {root}: {exc.strerror or exc}") from None
    atomic.write_text(root / DATASET_MARKER, json.dumps(DATASET_FORMAT) + "\n")
    return root


def is_dataset(root: str | os.PathLike[str]) -> bool:
    """Whether ``root`` is a dataset directory: it holds ``manifest.csv`` or the marker file."""
    root = Path(root)
    return (root / MANIFEST_NAME).is_file() or (root / DATASET_MARKER).is_file()


@contextlib.contextmanager
def dataset_lock(root: Path) -> Iterator[None]:
    """Hold an exclusive lock on the dataset's marker file (created if missing)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows: no lock
        yield
        return
    marker = root / DATASET_MARKER
    with open(marker, "a+", encoding="utf-8") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            if handle.tell() == 0:  # a dataset made by the simulator: mark it too
                handle.write(json.dumps(DATASET_FORMAT) + "\n")
                handle.flush()
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def manifest_rows(root: Path) -> tuple[list[str], list[list[str]]]:
    """Header and rows of ``manifest.csv`` as written (strings), validated; empty if none."""
    import csv

    path = root / MANIFEST_NAME
    if not path.exists():
        return [], []
    read_manifest(root)  # the usual checks: parses, a trial column, unique trials
    with path.open(encoding="utf-8", newline="") as handle:
        rows = [row for row in csv.reader(handle) if any(cell.strip() for cell in row)]
    return rows[0], rows[1:]


def _format(value: object) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)
    return str(value)


def append_manifest_row(root: Path, header: list[str], rows: list[list[str]], new: dict) -> int:
    """Append the row ``new`` to the manifest (new columns added, empty in old rows); atomic.

    ``header`` and ``rows`` are the manifest as :func:`manifest_rows` read it (under
    :func:`dataset_lock`); returns the number of trials it lists now.
    """
    import csv
    import io

    header = list(header) or ["trial"]
    header += [key for key in new if key not in header]
    width = len(header)
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(header)
    for row in rows:
        writer.writerow([*row, *[""] * (width - len(row))])
    writer.writerow([_format(new.get(key)) for key in header])
    atomic.write_text(root / MANIFEST_NAME, out.getvalue())
    read_manifest(root)  # what was written reads back (it was built from checked values)
    return len(rows) + 1
