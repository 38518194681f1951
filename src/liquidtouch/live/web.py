"""The live view in a browser: a small starlette app over a :class:`~liquidtouch.live.hub.LiveHub`.

Three routes, nothing else (any other path is a 404, any other method a 405):

- ``GET /``: the page (``static/live.html``: self-contained, inline script and
  style drawing SVG by hand; nothing is loaded from elsewhere, which its
  Content-Security-Policy also enforces);
- ``GET /stream``: server-sent events: ``update`` (one update's JSON, ``id`` its
  sequence number; the history first, then new ones; a reconnecting browser
  resumes after ``Last-Event-ID``), ``frames`` (``{sensor: version}`` when a
  sensor has a newer frame) and ``end`` (the stream is over);
- ``GET /frame/{sensor}.jpg``: the sensor's newest frame with its marker
  displacement arrows (JPEG).

The endpoints (:func:`page`, :func:`events`, :func:`frame`) are module-level
functions reading what they share from ``request.app.state`` (the hub, the stop
signal, the page, the count of open streams), set by :func:`create_app`;
:func:`lifespan` does the startup and shutdown work (the shutdown ends the open
streams). Server events (a client connected or disconnected, errors) go to the
``liquidtouch.live.web`` logger. :func:`start_server` runs the app with uvicorn
on a background thread, bound to 127.0.0.1 unless told otherwise.
"""

from __future__ import annotations

import contextlib
import ipaddress
import json
import logging
import socket
import threading
import time
from collections.abc import AsyncIterator
from pathlib import Path

import anyio
from starlette.applications import Starlette
from starlette.datastructures import State
from starlette.middleware import Middleware
from starlette.middleware.trustedhost import TrustedHostMiddleware
from starlette.requests import Request
from starlette.responses import HTMLResponse, Response, StreamingResponse
from starlette.routing import Route

from liquidtouch.errors import OutputError
from liquidtouch.live.hub import LiveHub

logger = logging.getLogger(__name__)

PAGE_PATH = Path(__file__).with_name("static") / "live.html"
#: the page may run its own inline script and style and fetch from its own origin, nothing else
CSP = (
    "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; "
    "img-src 'self'; connect-src 'self'; base-uri 'none'; form-action 'none'"
)
#: how often a stream looks for new frames when no update woke it [s]; also bounds shutdown
POLL_S = 0.1
#: a comment line this often keeps idle connections open through proxies [s]
KEEPALIVE_S = 15.0
#: Host headers accepted when bound to loopback (a DNS-rebinding page gets a 400)
LOOPBACK_HOSTS = ["127.0.0.1", "localhost", "::1", "[::1]"]
#: every response is live: never cached
NO_STORE = {"Cache-Control": "no-store"}


def _event(name: str, data: str, seq: int | None = None) -> str:
    head = f"id: {seq}\n" if seq is not None else ""
    return f"{head}event: {name}\ndata: {data}\n\n"


# endpoints: module-level, the shared state in ``request.app.state`` (see create_app)


async def page(request: Request) -> Response:
    """``GET /``: the self-contained page, under its Content-Security-Policy."""
    headers = {**NO_STORE, "Content-Security-Policy": CSP}
    return HTMLResponse(request.app.state.page, headers=headers)


async def events(request: Request) -> Response:
    """``GET /stream``: the server-sent events, resuming after ``Last-Event-ID``."""
    try:
        seq = int(request.headers.get("last-event-id", "0"))
    except ValueError:
        seq = 0
    headers = {**NO_STORE, "X-Accel-Buffering": "no"}
    stream = _watched(request.app.state, seq, request.client)
    return StreamingResponse(stream, media_type="text/event-stream", headers=headers)


async def frame(request: Request) -> Response:
    """``GET /frame/{sensor}.jpg``: the sensor's newest frame with its arrows (404: no such)."""
    sensor = request.path_params["sensor"]
    try:
        jpeg = await anyio.to_thread.run_sync(request.app.state.hub.frame_jpeg, sensor)
    except Exception:
        logger.exception("live view: the frame of sensor %r could not be drawn", sensor)
        raise
    if jpeg is None:
        return Response("no such sensor", status_code=404, media_type="text/plain")
    return Response(jpeg, media_type="image/jpeg", headers=NO_STORE)


async def _watched(state: State, seq: int, client: object) -> AsyncIterator[str]:
    """The event stream of one browser, counted in ``state.readers`` while it is open."""
    yield "retry: 1000\n\n"  # a browser that lost the stream retries after 1 s
    state.readers += 1
    logger.info("live view: %s connected (%d watching)", _who(client), state.readers)
    try:
        async for event in _news(state.hub, state.stopping, seq):
            yield event
    except Exception:
        logger.exception("live view: the event stream of %s failed", _who(client))
        raise
    finally:
        state.readers -= 1
        logger.info("live view: %s disconnected (%d watching)", _who(client), state.readers)


async def _news(hub: LiveHub, stopping: threading.Event, seq: int) -> AsyncIterator[str]:
    """The events after update ``seq``: updates, frame versions, keep-alives, then ``end``."""
    versions: dict[str, int] = {}
    last_sent = time.monotonic()
    while True:
        # read ``stopping`` first: what was published before the stop is still sent
        stopped = stopping.is_set()
        items, closed = hub.updates_since(seq)
        for item_seq, text in items:
            yield _event("update", text, item_seq)
            seq = item_seq
        sent = bool(items)
        if hub.frame_versions() != versions:
            versions = hub.frame_versions()
            yield _event("frames", json.dumps(versions))
            sent = True
        if (closed and not items) or stopped:
            yield _event("end", "{}")  # the server stopping ends the stream too
            return
        if sent:
            last_sent = time.monotonic()
        elif time.monotonic() - last_sent > KEEPALIVE_S:
            last_sent = time.monotonic()
            yield ": keep-alive\n\n"
        # block a worker thread, not the event loop, until an update or POLL_S
        # (frames are looked at every POLL_S: the page shows them at ~10 Hz)
        await anyio.to_thread.run_sync(hub.wait, seq, POLL_S)


def _who(client: object) -> str:
    """``host:port`` of a request's client, for the log."""
    host, port = getattr(client, "host", None), getattr(client, "port", None)
    return f"{host}:{port}" if host is not None else "a client"


@contextlib.asynccontextmanager
async def lifespan(app: Starlette) -> AsyncIterator[None]:
    """Startup and shutdown of the app: log them; on shutdown end every open stream."""
    logger.info("live view: serving")
    try:
        yield
    finally:
        app.state.stopping.set()
        logger.info("live view: stopped (%d still watching)", app.state.readers)


def _get_only(path: str, endpoint) -> Route:
    """A GET route that answers nothing else (starlette would add HEAD): 405 otherwise."""
    route = Route(path, endpoint, methods=["GET"])
    route.methods = {"GET"}
    return route


ROUTES = [
    _get_only("/", page),
    _get_only("/stream", events),
    _get_only("/frame/{sensor}.jpg", frame),
]


class _BrowserGone(logging.Filter):
    """asyncio's "socket.send() raised exception." when a browser closed its page: not an
    error of ours; logged at DEBUG on this module's logger instead."""

    def filter(self, record: logging.LogRecord) -> bool:
        if record.getMessage().startswith("socket.send() raised exception"):
            logger.debug("live view: a browser went away while being sent to")
            return False
        return True


logging.getLogger("asyncio").addFilter(_BrowserGone())


def create_app(
    hub: LiveHub,
    *,
    allowed_hosts: list[str] | None = None,
    stopping: threading.Event | None = None,
) -> Starlette:
    """The live view's ASGI app over ``hub``.

    ``allowed_hosts`` restricts the Host header (None: any); ``stopping``, once
    set, ends every open stream after what was already published (the server
    is shutting down; the app's shutdown sets it too). ``app.state`` holds the
    ``hub``, ``stopping``, the ``page`` and ``readers``, the number of open
    streams (browsers watching).
    """
    middleware = []
    if allowed_hosts is not None:
        middleware.append(Middleware(TrustedHostMiddleware, allowed_hosts=allowed_hosts))
    app = Starlette(routes=ROUTES, middleware=middleware, lifespan=lifespan)
    app.state.hub = hub
    app.state.stopping = stopping or threading.Event()
    app.state.page = PAGE_PATH.read_text(encoding="utf-8")
    app.state.readers = 0
    return app


class LiveServer:
    """A running live view: ``url``, ``stop()``; a context manager that stops on exit."""

    def __init__(self, server, thread: threading.Thread, stopping: threading.Event, url: str):
        self.app = server.config.app
        self._server = server
        self._thread = thread
        self._stopping = stopping
        self.url = url

    def stop(self, timeout_s: float = 5.0) -> None:
        """End the streams and the server; wait at most ``timeout_s`` [s] for its thread."""
        self._stopping.set()
        self._server.should_exit = True
        self._thread.join(timeout_s / 2)
        if self._thread.is_alive():  # a client that does not let go: close connections now
            self._server.force_exit = True
            self._thread.join(timeout_s / 2)

    @property
    def readers(self) -> int:
        """Open streams: browsers watching now."""
        return int(self.app.state.readers)

    def __enter__(self) -> LiveServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def _is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def start_server(
    hub: LiveHub, host: str = "127.0.0.1", port: int = 0, *, timeout_s: float = 10.0
) -> LiveServer:
    """Serve the live view of ``hub`` on ``host:port`` (0: any free port) on a background thread.

    Returns once the server accepts connections (at most ``timeout_s`` [s]);
    ``.url`` has the real port. Raises :class:`~liquidtouch.errors.OutputError`
    when the address cannot be bound or the server does not start in time.
    """
    import uvicorn

    host = host.strip("[]")
    sock = None
    try:
        family, kind, proto, _, address = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)[0]
        sock = socket.socket(family, kind, proto)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(address)
    except OSError as err:
        if sock is not None:
            sock.close()
        raise OutputError(f"cannot serve the live view on {host}:{port}: {err}") from None
    bound = sock.getsockname()[1]
    stopping = threading.Event()
    allowed = LOOPBACK_HOSTS if _is_loopback(host) else None
    config = uvicorn.Config(
        create_app(hub, allowed_hosts=allowed, stopping=stopping),
        log_config=None,  # leave the application's logging alone
        log_level="warning",
        access_log=False,
        lifespan="on",  # logs start and stop; its shutdown ends the streams
        server_header=False,
        timeout_graceful_shutdown=2,
    )
    server = uvicorn.Server(config)
    thread = threading.Thread(
        target=server.run, kwargs={"sockets": [sock]}, name="liquidtouch-live-web", daemon=True
    )
    thread.start()
    deadline = time.monotonic() + timeout_s
    while not server.started:
        if not thread.is_alive() or time.monotonic() > deadline:
            server.should_exit = True
            thread.join(1.0)
            sock.close()
            raise OutputError(f"the live view did not start on {host}:{bound} in {timeout_s:g} s")
        time.sleep(0.01)
    shown = f"[{host}]" if ":" in host else host
    return LiveServer(server, thread, stopping, f"http://{shown}:{bound}/")
