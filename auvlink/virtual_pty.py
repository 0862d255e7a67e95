"""The pty: the far end of a serial line, for the simulator, the tests and the slcan adapter emulator.

A driver cannot tell it from hardware: it opens the slave path of a :class:`PtyPair` with the ordinary
serial transport.

    with PtyPair() as pty, Driver("fog", "dsp1760", pty.device_path) as fog:
        pty.write(frame_bytes)          # the instrument's side (the simulator, a test)
        samples = fog.read(timeout=0.5)  # the driver's side, exactly as on /dev/ttyUSB0

The master side of a pty is also a :class:`~auvlink.transports.base.Transport`: ``pty://``
(anonymous) or ``pty:///tmp/auv/fog`` (a symlink at that path names the slave, so a
configuration file can say ``/tmp/auv/fog`` for the driver in another process). Query keys:
``lossy=1`` (a write that finds the line full discards the rest and counts it, as a UART with
nobody listening does; default: wait) and ``write_timeout`` (s, when not lossy).
"""

from __future__ import annotations

import fcntl
import os
import select
import termios
import tty
from pathlib import Path
from types import TracebackType
from typing import ClassVar

from auvlink.errors import TransportInitError, TransportOperationError, TransportTimeoutError
from auvlink.transports.base import Transport, url_query

__all__ = ["PtyPair", "PtyTransport"]

READ_CHUNK = 1 << 16
_TRUE = ("1", "true", "yes", "on")


class PtyPair:
    """A raw-mode pseudo-terminal; :attr:`device_path` is the port a driver opens.

    This object is the instrument's end (the pty master). It keeps one descriptor of the slave
    open itself, so the line survives a driver closing and reopening the port, and bytes written
    while no driver listens wait in the kernel buffer (about 64 KiB) like in a UART FIFO.
    """

    def __init__(self, link: str | os.PathLike[str] | None = None, *, lossy: bool = False,
                 write_timeout: float | None = None) -> None:
        self.link = Path(link) if link is not None else None
        self.lossy = lossy
        self.write_timeout = write_timeout
        self.bytes_discarded = 0
        self._master: int | None = None
        self._slave: int | None = None
        self._slave_name = ""

    # -- life cycle -----------------------------------------------------------------------
    def open(self) -> PtyPair:
        if self._master is not None:
            return self
        master, slave = os.openpty()
        try:
            tty.setraw(slave)  # no echo, no CR/LF translation, no signals: bytes pass unchanged
            os.set_blocking(master, False)
            name = os.ttyname(slave)
            if self.link is not None:
                if self.link.exists() and not self.link.is_symlink():
                    raise TransportInitError(f"{self.link} exists and is not a symlink")
                self.link.unlink(missing_ok=True)
                self.link.parent.mkdir(parents=True, exist_ok=True)
                self.link.symlink_to(name)
        except BaseException:
            os.close(master)
            os.close(slave)
            raise
        self._master, self._slave, self._slave_name = master, slave, name
        return self

    def close(self) -> None:
        master, slave, self._master, self._slave = self._master, self._slave, None, None
        if master is None:
            return
        if self.link is not None and self.link.is_symlink():
            self.link.unlink(missing_ok=True)
        os.close(master)  # the driver's end now reads EIO: "device gone"
        if slave is not None:
            os.close(slave)

    @property
    def is_open(self) -> bool:
        return self._master is not None

    def __enter__(self) -> PtyPair:
        return self.open()

    def __exit__(self, et: type[BaseException] | None, ev: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"PtyPair({self._slave_name or '-'}, link={self.link}, open={self.is_open})"

    # -- the driver's side ----------------------------------------------------------------
    @property
    def device_path(self) -> str:
        """What a driver opens: the symlink when one was asked for, else the slave (/dev/pts/N)."""
        if self._master is None:
            raise TransportOperationError("PtyPair is not open")
        return str(self.link) if self.link is not None else self._slave_name

    @property
    def slave_name(self) -> str:
        return self._slave_name

    # -- the instrument's side (pyserial-like) --------------------------------------------
    def fileno(self) -> int:
        if self._master is None:
            raise TransportOperationError("PtyPair is not open")
        return self._master

    @property
    def in_waiting(self) -> int:
        """Bytes the driver wrote that wait to be read here."""
        buf = bytearray(4)
        fcntl.ioctl(self.fileno(), termios.FIONREAD, buf)
        return int.from_bytes(buf, "little")

    def read(self, size: int = READ_CHUNK, timeout: float | None = 0.1) -> bytes:
        """Up to ``size`` bytes the driver wrote, waiting at most ``timeout`` s for the first."""
        fd = self.fileno()
        ready, _, _ = select.select([fd], [], [], timeout)
        if not ready:
            return b""
        try:
            return os.read(fd, size)
        except BlockingIOError:
            return b""
        except OSError as exc:
            raise TransportOperationError(f"pty {self._slave_name}: read failed: {exc}") from exc

    def write(self, data: bytes) -> int:
        """Send ``data`` to the driver; returns the bytes delivered (all, unless lossy)."""
        fd = self.fileno()
        view = memoryview(data)
        sent = 0
        while sent < len(view):
            try:
                sent += os.write(fd, view[sent:])
                continue
            except BlockingIOError:
                pass
            except OSError as exc:
                raise TransportOperationError(f"pty {self._slave_name}: write failed: {exc}") from exc
            if self.lossy:
                self.bytes_discarded += len(view) - sent
                return sent
            _, ready, _ = select.select([], [fd], [], self.write_timeout)
            if not ready:
                raise TransportTimeoutError(
                    f"pty {self._slave_name}: nobody read {len(view) - sent} bytes within "
                    f"{self.write_timeout} s"
                )
        return sent

    def flush(self) -> None:
        """Wait until the driver's end holds everything written (no-op: the kernel has it)."""

    def transport(self) -> PtyTransport:
        """This end as a :class:`Transport` (not owning the pty: closing it leaves the pty open)."""
        return PtyTransport(f"pty://{self.link or ''}", pair=self)


class PtyTransport(Transport):
    """The instrument's end of a pty as a transport (``pty://`` or ``pty:///path/of/link``)."""

    schemes: ClassVar[tuple[str, ...]] = ("pty",)

    def __init__(self, url: str, pair: PtyPair | None = None) -> None:
        super().__init__(url)
        self._owns = pair is None
        if pair is None:
            query = url_query(url)
            path = url[len("pty://"):].partition("?")[0]
            timeout = query.get("write_timeout")
            pair = PtyPair(path or None, lossy=query.get("lossy", "0").lower() in _TRUE,
                           write_timeout=float(timeout) if timeout else None)
        self.pair = pair

    @property
    def device_path(self) -> str:
        """The path the driver opens."""
        return self.pair.device_path

    def _open(self) -> None:
        if self._owns:
            self.pair.open()
        elif not self.pair.is_open:
            raise TransportInitError(f"{self.url}: the pty pair is closed")

    def _close(self) -> None:
        if self._owns:
            self.pair.close()

    def _read(self, timeout: float | None) -> bytes:
        return self.pair.read(READ_CHUNK, timeout)

    def _write(self, data: bytes) -> None:
        self.pair.write(data)
