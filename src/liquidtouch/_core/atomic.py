"""Atomic writes: build the output beside the target, then rename it into place.

A crash never leaves a half-written file under the target name. An output
that cannot be written (the target is a directory, its parent is a file or
read-only, the disk is full) raises :class:`~liquidtouch.errors.OutputError`
and leaves nothing behind.

Multi-file outputs (a trial directory) use :func:`atomic_directory`: the
whole directory is built in a temporary directory beside the target and
swapped in at the end, so a failure or Ctrl-C leaves the old directory as it
was and no temporary directory behind.
"""

from __future__ import annotations

import contextlib
import json
import os
import secrets
import shutil
import signal
import tempfile
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from liquidtouch.errors import OutputError


@contextlib.contextmanager
def atomic_path(target: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path next to ``target``; rename it onto ``target`` on success.

    The temporary file keeps the target's suffix, so writers that choose a
    format by extension (matplotlib, PyAV, ``np.savez``) still work.
    """
    _refuse_directory_spelling(target)
    target = Path(target)
    if target.is_dir():
        raise OutputError(f"cannot write {target}: it is a directory; give a file name")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp_name = tempfile.mkstemp(
            prefix=f".{target.stem}.", suffix=f".tmp{target.suffix}", dir=target.parent
        )
    except OSError as exc:
        raise OutputError(_os_message(target, exc)) from None
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        try:
            yield tmp
            if tmp.exists():  # mkstemp makes 0600 files; give the usual umask-based mode
                os.chmod(tmp, _umask_mode(0o666))
            os.replace(tmp, target)
        except OSError as exc:
            raise OutputError(_os_message(target, exc)) from None
    finally:
        if tmp.exists():
            tmp.unlink()


def _refuse_directory_spelling(target: str | os.PathLike[str]) -> None:
    """Refuse a file target spelled as a directory: empty, or ending in a path separator."""
    text = os.fspath(target)
    if isinstance(text, bytes):
        text = os.fsdecode(text)
    if text == "":
        raise OutputError("cannot write an empty path; give a file name")
    if text.endswith(("/", os.sep)):
        raise OutputError(
            f"cannot write {text}: a path ending in {text[-1]!r} names a directory; "
            "give a file name"
        )


@contextlib.contextmanager
def deferred_interrupt() -> Iterator[None]:
    """Hold back Ctrl-C (SIGINT) and SIGTERM inside the block; act on them at its end.

    For the few steps that must not be cut in two (swapping a directory into
    place, removing a temporary one). A signal received meanwhile is handed to
    the previous handler at the end of the block (Ctrl-C: KeyboardInterrupt);
    an ignored signal stays ignored. Outside the main thread (where no signal
    handler can be set) it does nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []
    previous: dict[int, Any] = {}
    try:
        for signum in (signal.SIGINT, signal.SIGTERM):
            handler = signal.getsignal(signum)
            if handler in (signal.SIG_IGN, None):
                continue
            previous[signum] = signal.signal(signum, lambda num, frame: received.append(num))
    except ValueError:  # pragma: no cover - not the main interpreter
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        yield
        return
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    for signum in dict.fromkeys(received):
        handler = previous[signum]
        if callable(handler):
            handler(signum, None)
        else:  # SIG_DFL: deliver it again, now that the default action is back
            signal.raise_signal(signum)


def _umask_mode(mode: int) -> int:
    umask = os.umask(0)
    os.umask(umask)
    return mode & ~umask


@contextlib.contextmanager
def atomic_directory(
    target: str | os.PathLike[str],
    *,
    replaceable: Callable[[Path], str | None] | None = None,
) -> Iterator[Path]:
    """Yield a new empty directory beside ``target``; on success swap it in as ``target``.

    Every file of the output is written into the yielded directory. At the end
    an existing ``target`` is renamed aside, the new directory renamed in, and
    the old one deleted; if the block fails (an exception, Ctrl-C) the
    temporary directory is removed and ``target`` is left exactly as it was.

    An existing ``target`` must be a directory that ``replaceable(target)``
    accepts: it returns ``None`` if the directory may be replaced, else the
    reason why not (default: only an empty directory may be replaced). Raises
    :class:`~liquidtouch.errors.OutputError` for a target that cannot be written.
    """
    target = check_directory_target(target, replaceable=replaceable)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent))
    except OSError as exc:
        raise OutputError(_os_message(target, exc)) from None
    try:
        try:
            yield tmp
            with deferred_interrupt():
                os.chmod(tmp, _umask_mode(0o777))
                _swap_in(tmp, target)
        except OSError as exc:
            raise OutputError(_os_message(target, exc)) from None
    finally:
        if tmp.exists():
            with deferred_interrupt():
                shutil.rmtree(tmp, ignore_errors=True)


def check_directory_target(
    target: str | os.PathLike[str], *, replaceable: Callable[[Path], str | None] | None = None
) -> Path:
    """Check that ``target`` can become (or be replaced by) a new directory; return its path.

    Raises :class:`~liquidtouch.errors.OutputError` if ``target`` is empty, is
    (or holds) the current directory or the file-system root, exists as
    something other than a directory, or is a directory that ``replaceable``
    refuses (see :func:`atomic_directory`). Writes nothing.
    """
    if os.fspath(target) in ("", b""):
        raise OutputError("cannot write an empty path; give a directory name")
    try:
        return _checked_directory_target(target, replaceable)
    except OSError as exc:  # a name too long, an unreadable parent...
        raise OutputError(_os_message(Path(target), exc)) from None


def _checked_directory_target(
    target: str | os.PathLike[str], replaceable: Callable[[Path], str | None] | None
) -> Path:
    path = Path(os.path.realpath(target))  # follows a symlinked target to its directory
    if path.parent == path:
        raise OutputError(f"cannot write {target}: give a directory below the root")
    with contextlib.suppress(OSError):  # the current directory may have been deleted
        cwd = Path.cwd().resolve()
        if path == cwd or path in cwd.parents:
            raise OutputError(
                f"cannot write {target}: it holds the current directory; give a new directory name"
            )
    if path.exists() or path.is_symlink():
        if not path.is_dir():
            raise OutputError(
                f"cannot write {target}: it exists and is not a directory; choose a directory path"
            )
        reason = (replaceable or _empty_reason)(path)
        if reason is not None:
            raise OutputError(f"will not replace {target}: {reason}")
        return path
    for parent in path.parents:  # the nearest existing ancestor must be a directory
        if parent.exists():
            if not parent.is_dir():
                raise OutputError(
                    f"cannot write {target}: {parent} is a file, not a directory; "
                    "choose another output path"
                )
            break
    return path


def _empty_reason(path: Path) -> str | None:
    return None if not any(path.iterdir()) else "it is not empty"


def _swap_in(new: Path, target: Path) -> None:
    """Rename ``new`` to ``target``; an existing ``target`` is renamed aside, then deleted."""
    if not target.exists():
        os.rename(new, target)
        return
    old = target.with_name(f".{target.name}.{secrets.token_hex(4)}.old")
    os.rename(target, old)
    try:
        os.rename(new, target)
    except BaseException:
        os.rename(old, target)
        raise
    shutil.rmtree(old, ignore_errors=True)


def _os_message(target: Path, exc: OSError) -> str:
    reason = exc.strerror or type(exc).__name__
    return f"cannot write {target}: {reason}; choose another output path"


def write_text(target: str | os.PathLike[str], text: str) -> None:
    """Atomically write ``text`` (UTF-8) to ``target``."""
    with atomic_path(target) as tmp:
        tmp.write_text(text, encoding="utf-8")


def write_bytes(target: str | os.PathLike[str], data: bytes) -> None:
    """Atomically write ``data`` to ``target``."""
    with atomic_path(target) as tmp:
        tmp.write_bytes(data)


def write_json(target: str | os.PathLike[str], obj: Any) -> None:
    """Atomically write ``obj`` as indented JSON to ``target``."""
    write_text(target, json.dumps(obj, indent=2, sort_keys=False) + "\n")
