"""Device addressing and line transport shared by the gripper and arm clients.

:func:`parse_device_url` splits a ``scheme://HOST[:PORT]`` device URL;
:class:`LineConnection` carries ``\\n``-terminated ASCII lines over TCP with a
deadline on every read (the WSG-50's GCL and the simulated rig's arm protocol).
"""

from __future__ import annotations

import logging
import socket
import time
from dataclasses import dataclass
from urllib.parse import urlsplit

from liquidtouch.errors import DeviceError

__all__ = ["DeviceAddress", "LineConnection", "parse_device_url"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class DeviceAddress:
    """A parsed device URL: ``scheme://host:port``."""

    scheme: str
    host: str
    port: int | None


def parse_device_url(url: str, schemes: tuple[str, ...], what: str) -> DeviceAddress:
    """Split ``url`` into scheme, host and port; :class:`DeviceError` if malformed or unknown."""
    if not isinstance(url, str) or "://" not in url:
        raise DeviceError(
            f"{what} {url!r} is not a URL; use one of: " + ", ".join(f"{s}://..." for s in schemes)
        )
    parts = urlsplit(url)
    scheme = parts.scheme.lower()
    if scheme not in schemes:
        raise DeviceError(
            f"unknown {what} scheme {parts.scheme!r} in {url!r}; use one of: "
            + ", ".join(f"{s}://" for s in schemes)
        )
    if parts.path not in ("", "/") or parts.query or parts.fragment:
        raise DeviceError(f"{what} {url!r} has a path or query; give only scheme://HOST[:PORT]")
    try:
        port = parts.port
    except ValueError:
        raise DeviceError(f"{what} {url!r} has a bad port; use a number 1-65535") from None
    if port == 0:
        raise DeviceError(f"{what} {url!r} has port 0; use a number 1-65535")
    return DeviceAddress(scheme, parts.hostname or "", port)


class LineConnection:
    """A TCP connection carrying ``\\n``-terminated ASCII lines; every read has a deadline."""

    def __init__(self, host: str, port: int, *, connect_timeout_s: float, what: str):
        self.what = what
        self._buffer = b""
        try:
            self._sock = socket.create_connection((host, port), timeout=connect_timeout_s)
        except OSError as exc:
            logger.info("cannot connect to the %s at %s:%s: %s", what, host, port, exc)
            raise DeviceError(
                f"cannot connect to the {what} at {host}:{port}: {exc.strerror or exc}; "
                "check that it is powered, on the network and that the address is right"
            ) from None
        self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.closed = False
        logger.debug("TCP connection to the %s at %s:%s open", what, host, port)

    def send_line(self, line: str) -> None:
        """Send one line (the ``\\n`` is added)."""
        if self.closed:
            raise DeviceError(f"the connection to the {self.what} is closed")
        try:
            self._sock.settimeout(5.0)
            self._sock.sendall(line.encode("ascii") + b"\n")
        except OSError as exc:
            self.close()
            logger.info("lost the connection to the %s while sending: %s", self.what, exc)
            raise DeviceError(
                f"lost the connection to the {self.what} while sending {line!r}: "
                f"{exc.strerror or exc}"
            ) from None

    def read_line(self, timeout_s: float, waiting_for: str) -> str:
        """The next line (without its line end); :class:`DeviceError` after ``timeout_s``."""
        deadline = time.monotonic() + timeout_s
        while b"\n" not in self._buffer:
            if self.closed:
                raise DeviceError(f"the connection to the {self.what} is closed")
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                logger.info("the %s did not answer within %.3g s", self.what, timeout_s)
                raise DeviceError(
                    f"the {self.what} did not answer within {timeout_s:.3g} s "
                    f"(waiting for {waiting_for})"
                )
            try:
                self._sock.settimeout(remaining)
                chunk = self._sock.recv(4096)
            except TimeoutError:
                continue
            except OSError as exc:
                self.close()
                logger.info("lost the connection to the %s: %s", self.what, exc)
                raise DeviceError(
                    f"lost the connection to the {self.what} while waiting for {waiting_for}: "
                    f"{exc.strerror or exc}"
                ) from None
            if not chunk:
                self.close()
                logger.info("the %s closed the connection", self.what)
                raise DeviceError(
                    f"the {self.what} closed the connection while we waited for {waiting_for}"
                )
            self._buffer += chunk
            if len(self._buffer) > 1 << 16 and b"\n" not in self._buffer:
                self.close()
                raise DeviceError(f"the {self.what} sent a line longer than 64 KiB")
        line, _, self._buffer = self._buffer.partition(b"\n")
        return line.decode("ascii", errors="replace").strip()

    def close(self) -> None:
        """Close the socket (idempotent)."""
        if not self.closed:
            self.closed = True
            try:
                self._sock.close()
            except OSError as exc:
                logger.debug("closing the connection to the %s: %s", self.what, exc)
