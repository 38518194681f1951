"""Where batch work runs: in-process, a process pool, or a Dask cluster.

Every option is a :class:`concurrent.futures.Executor`, so batch code does not
care which one it gets.

Ctrl-C with a process pool: the terminal sends SIGINT to the whole process
group, but pool workers ignore it, so only the parent sees the
KeyboardInterrupt. The parent then cancels the pending tasks and stops the
workers with SIGTERM, which a worker turns into an exception inside the
running task (so ``finally`` blocks and atomic writers clean up) before it
exits quietly: no worker tracebacks, no half-written outputs.
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
from collections.abc import Callable, Hashable, Iterator, Mapping
from concurrent.futures import Executor, Future, ProcessPoolExecutor, as_completed
from typing import Any

from liquidtouch._core.checks import check_int
from liquidtouch.errors import LiquidTouchError

logger = logging.getLogger(__name__)


class SerialExecutor(Executor):
    """Run each task at once in the calling process (``jobs=1``; easy to debug and profile)."""

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future:
        future: Future = Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # handed to the caller via the future
            if isinstance(exc, KeyboardInterrupt):
                raise
            future.set_exception(exc)
        return future


@contextlib.contextmanager
def open_executor(
    jobs: int = 1, dask_address: str | None = None, *, n_tasks: int | None = None
) -> Iterator[Executor]:
    """Yield an executor: Dask (``dask_address``), a process pool (``jobs > 1``) or serial.

    ``dask_address`` is a scheduler address such as ``tcp://127.0.0.1:8786``;
    it needs the optional extra ``liquidtouch[dask]``. A local pool never has
    more workers than cores or than ``n_tasks`` (idle workers only cost memory).
    """
    jobs = check_int(jobs, "`jobs`", 1, LiquidTouchError)
    jobs = min(jobs, os.cpu_count() or 1, n_tasks or jobs)
    if dask_address:
        try:
            from distributed import Client
        except ImportError:
            raise LiquidTouchError(
                "`dask_address` needs the optional extra: pip install 'liquidtouch[dask]'"
            ) from None
        try:
            client = Client(dask_address, timeout=10)
        except (OSError, ValueError, TypeError) as exc:  # unreachable, or not an address
            raise LiquidTouchError(
                f"cannot reach the Dask scheduler at {dask_address}: {exc}"
            ) from None
        logger.info("running on the Dask cluster at %s", dask_address)
        try:
            yield client.get_executor()
        finally:
            client.close()
    elif jobs == 1:
        yield SerialExecutor()
    else:
        logger.info("running on a pool of %d worker processes", jobs)
        pool = ProcessPoolExecutor(max_workers=jobs, initializer=_init_worker)
        try:
            yield pool
        except BaseException:
            logger.info("stopping the worker pool")
            _stop_pool(pool)
            raise
        pool.shutdown(wait=True)


WORKER_STOP_TIMEOUT_S = 30.0
"""How long the parent waits for stopped workers to clean up after Ctrl-C [s]."""


class _WorkerStopped(SystemExit):
    """Raised inside a worker's running task when the parent stops the pool (SIGTERM)."""


_task_running = False


def _init_worker() -> None:
    """Pool-worker start-up: ignore Ctrl-C (the parent handles it); SIGTERM stops the task."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _on_sigterm)


def _on_sigterm(signum: int, frame: object) -> None:
    if _task_running:
        raise _WorkerStopped(128 + signum)
    os._exit(128 + signum)  # idle: nothing to clean up


def _call_in_worker(fn: Callable[..., Any], *args: Any) -> Any:
    """Run one task in a pool worker; exit the worker at once once a stopped task has unwound."""
    global _task_running
    _task_running = True
    try:
        return fn(*args)
    except _WorkerStopped as exc:
        os._exit(exc.code if isinstance(exc.code, int) else 1)
    finally:
        _task_running = False


def _stop_pool(pool: ProcessPoolExecutor) -> None:
    """Cancel the pool's pending tasks and stop its workers (after Ctrl-C or an error)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        with contextlib.suppress(OSError, ValueError, AttributeError):
            process.terminate()
    for process in processes:
        with contextlib.suppress(OSError, ValueError, AssertionError, AttributeError):
            process.join(WORKER_STOP_TIMEOUT_S)


def run_each(
    pool: Executor, fn: Callable[..., Any], tasks: Mapping[Hashable, tuple]
) -> Iterator[tuple[Hashable, Future]]:
    """Run ``fn(*args)`` for each ``key: args`` of ``tasks``; yield ``(key, future)`` as each ends.

    On a :class:`SerialExecutor` tasks run one at a time as the caller
    consumes them, so progress bars move and an interrupted run stops at once.
    """
    if isinstance(pool, SerialExecutor):
        for key, args in tasks.items():
            yield key, pool.submit(fn, *args)
        return
    if isinstance(pool, ProcessPoolExecutor):
        futures = {pool.submit(_call_in_worker, fn, *args): key for key, args in tasks.items()}
    else:
        futures = {pool.submit(fn, *args): key for key, args in tasks.items()}
    for future in as_completed(futures):
        yield futures[future], future
