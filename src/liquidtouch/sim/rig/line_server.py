"""The TCP accept loop shared by the simulated rig's line-based servers.

:class:`LineServer` binds ``host:port`` (``port=0``: any free port; ``port`` holds the
bound port after ``start()``), accepts clients on a daemon thread and serves each on
its own thread through a connection object (``sock``, ``cancelled``, ``serve()``)
made by the subclass's ``_connection``. ``stop()`` closes everything.
"""

from __future__ import annotations

import contextlib
import logging
import socket
import threading
from typing import Any, Protocol, Self

__all__ = ["LineConnection", "LineServer"]

logger = logging.getLogger(__name__)


class LineConnection(Protocol):
    """One client's connection, as :class:`LineServer` drives it."""

    sock: socket.socket
    cancelled: threading.Event

    def serve(self) -> None: ...


class LineServer:
    """Accept clients on ``host:port`` and serve each on its own thread.

    Subclasses set ``thread_name`` and implement ``_connection(client)``.
    """

    thread_name = "rig-line"

    def __init__(self, model: Any, *, host: str = "127.0.0.1", port: int = 0):
        self.model, self.host, self.port = model, host, port
        self.stopping = threading.Event()
        self._sock: socket.socket | None = None
        self._thread: threading.Thread | None = None
        self._connections: list[LineConnection] = []
        self._lock = threading.Lock()

    def _connection(self, client: socket.socket) -> LineConnection:
        raise NotImplementedError

    def start(self) -> Self:
        sock = socket.create_server((self.host, self.port))
        sock.settimeout(0.2)
        self._sock, self.port = sock, sock.getsockname()[1]
        logger.info("%s listening on %s:%d", self.thread_name, self.host, self.port)
        self._thread = threading.Thread(target=self._accept, name=self.thread_name, daemon=True)
        self._thread.start()
        return self

    def _accept(self) -> None:
        assert self._sock is not None
        while not self.stopping.is_set():
            try:
                client, _ = self._sock.accept()
            except TimeoutError:
                continue
            except OSError as exc:
                if not self.stopping.is_set():
                    logger.warning("%s stopped accepting: %s", self.thread_name, exc)
                break
            client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            connection = self._connection(client)
            with self._lock:
                self._connections = [c for c in self._connections if c.sock.fileno() >= 0]
                self._connections.append(connection)
            threading.Thread(
                target=connection.serve, name=f"{self.thread_name}-client", daemon=True
            ).start()

    def stop(self) -> None:
        self.stopping.set()
        if self._sock is not None:
            with contextlib.suppress(OSError):
                self._sock.close()
        with self._lock:
            for connection in self._connections:
                connection.cancelled.set()
                with contextlib.suppress(OSError):
                    connection.sock.shutdown(socket.SHUT_RDWR)
        if self._thread is not None:
            self._thread.join(timeout=2.0)

    def __enter__(self) -> Self:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
