"""An slcan (Lawicel CAN-USB ASCII protocol) adapter emulator on a pty.

A real USB-CAN adapter (CANable, CANtact, Lawicel CANUSB) shows up as a serial port; the host
talks to it in short ASCII commands ending in CR and gets CR (ok) or BEL (error) back, and every
bus frame arrives as a ``t``/``T`` line. :class:`SlcanAdapter` plays that adapter on the master
side of a :class:`~auvlink.virtual_pty.PtyPair`, and is itself a python-can bus: the process that owns
it is a CAN node (it ``send``\\ s frames the host will receive, and ``recv``\\ s what the host
transmits), while the host opens ``can://slcan/<device_path>`` exactly as it would a real adapter.

Commands (Lawicel CANUSB manual, "ASCII command set"; CANable/python-can extensions marked +):
``O`` open, ``L`` open listen-only, ``C`` close, ``Sn`` bit rate (n = 0..8, +9 = 83.3 k),
``sxxyy`` BTR registers, ``+Yn`` FD data rate, ``V`` version, ``v`` +firmware version, ``N``
serial number, ``F`` status flags, ``Zn`` time stamps off/on, ``Mxxxxxxxx``/``mxxxxxxxx``
acceptance code/mask, ``tiiiL..``/``TiiiiiiiiL..``/``riiiL``/``RiiiiiiiiL`` transmit, +``d D b B``
CAN FD transmit; an empty command answers CR. Transmit replies ``z`` (11-bit) / ``Z`` (29-bit).
"""

from __future__ import annotations

import os
import queue
import threading
import time
from typing import Any

import can
from can.util import CAN_FD_DLC, len2dlc

from auvlink.errors import DecodeError, TransportError, TransportTimeoutError
from auvlink.virtual_pty import PtyPair

OK, ERROR = b"\r", b"\a"
#: Sn -> bit rate (python-can's table; S9 is its 83.3 kbit/s extension)
BITRATES = {0: 10_000, 1: 20_000, 2: 50_000, 3: 100_000, 4: 125_000, 5: 250_000, 6: 500_000,
            7: 750_000, 8: 1_000_000, 9: 83_300}
_FRAME_KINDS = {  # letter -> (extended id, remote, fd, bit-rate switch)
    "t": (False, False, False, False), "T": (True, False, False, False),
    "r": (False, True, False, False), "R": (True, True, False, False),
    "d": (False, False, True, False), "D": (True, False, True, False),
    "b": (False, False, True, True), "B": (True, False, True, True),
}


def encode_slcan(msg: can.Message, timestamp_ms: int | None = None) -> bytes:
    """The slcan line (CR included) that carries ``msg``; ``timestamp_ms`` appends 4 hex digits."""
    ident = f"{msg.arbitration_id:08X}" if msg.is_extended_id else f"{msg.arbitration_id:03X}"
    if msg.is_fd:
        letter = ("B" if msg.is_extended_id else "b") if msg.bitrate_switch else (
            "D" if msg.is_extended_id else "d")
        line = f"{letter}{ident}{len2dlc(len(msg.data)):X}{bytes(msg.data).hex().upper()}"
    elif msg.is_remote_frame:
        line = f"{'R' if msg.is_extended_id else 'r'}{ident}{msg.dlc:d}"
    else:
        line = f"{'T' if msg.is_extended_id else 't'}{ident}{msg.dlc:d}{bytes(msg.data).hex().upper()}"
    if timestamp_ms is not None:
        line += f"{timestamp_ms % 60_000:04X}"
    return line.encode("ascii") + OK


def decode_slcan(line: str) -> can.Message:
    """The ``can.Message`` of one slcan frame command (without its CR); raises DecodeError."""
    kind = _FRAME_KINDS.get(line[:1])
    if kind is None:
        raise DecodeError(f"slcan: not a frame command: {line!r}", fmt="slcan")
    extended, remote, fd, brs = kind
    id_len = 8 if extended else 3
    try:
        ident = int(line[1:1 + id_len], 16)
        code = int(line[1 + id_len], 16)
        length = CAN_FD_DLC[code] if fd else code
        if len(line[1:1 + id_len]) != id_len or (not fd and code > 8) or ident >= (
                1 << (29 if extended else 11)):
            raise ValueError("identifier or length out of range")
        start = 2 + id_len
        data = b"" if remote else bytes.fromhex(line[start:start + 2 * length])
        if len(data) != (0 if remote else length):
            raise ValueError(f"expected {length} data bytes")
    except (ValueError, IndexError) as exc:
        raise DecodeError(f"slcan: bad frame {line!r}: {exc}", fmt="slcan") from exc
    return can.Message(arbitration_id=ident, is_extended_id=extended, is_remote_frame=remote,
                       is_fd=fd, bitrate_switch=brs, dlc=length, data=data, timestamp=time.time())


class SlcanAdapter(can.BusABC):
    """A USB-CAN adapter on a pty: ``device_path`` for the host, a python-can bus for this node.

    Frames sent while the host has not opened the channel (``O``) never reach it, as on a real
    bus; :meth:`wait_open` waits for the host. Counters: :attr:`to_host`, :attr:`from_host`,
    :attr:`dropped` and :attr:`errors` (commands answered with BEL); :attr:`commands` lists
    every command received, in order.
    """

    def __init__(self, channel: str | os.PathLike[str] | None = None, *, serial_number: str = "A001",
                 version: str = "1013", **kwargs: Any) -> None:
        self.pty = PtyPair(channel, write_timeout=2.0).open()
        self.serial_number, self.version = serial_number, version
        self.bitrate: int | None = None
        self.listen_only = self.timestamps = False
        self.commands: list[str] = []
        self.to_host = self.from_host = self.dropped = self.errors = 0
        self._opened = threading.Event()
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._rx: queue.SimpleQueue[can.Message] = queue.SimpleQueue()
        self._t0 = time.monotonic()
        super().__init__(channel=self.pty.device_path, **kwargs)
        self.channel_info = f"slcan adapter emulator on {self.pty.device_path}"
        self._thread = threading.Thread(target=self._serve, name=self.channel_info, daemon=True)
        self._thread.start()

    @property
    def device_path(self) -> str:
        return self.pty.device_path

    def url(self, bitrate: int = 500_000, **options: object) -> str:
        """The host's ``can://slcan/...`` URL (no 2 s settling sleep: the emulator needs none)."""
        query = "&".join(f"{k}={v}" for k, v in {"bitrate": bitrate, "sleep_after_open": 0,
                                                  **options}.items())
        return f"can://slcan/{self.device_path}?{query}"

    @property
    def is_open(self) -> bool:
        """Whether the host has opened the CAN channel (``O`` or ``L``)."""
        return self._opened.is_set()

    def wait_open(self, timeout: float = 5.0) -> None:
        if not self._opened.wait(timeout):
            raise TransportTimeoutError(f"{self.channel_info}: host did not open the channel "
                                        f"within {timeout} s")

    # -- this node on the bus ---------------------------------------------------------------
    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        if not self._opened.is_set():
            self.dropped += 1
            return
        stamp = int((time.monotonic() - self._t0) * 1000) if self.timestamps else None
        try:
            self._reply(encode_slcan(msg, stamp))
        except TransportError as exc:
            raise can.CanOperationError(f"{self.channel_info}: host does not read: {exc}") from exc
        self.to_host += 1

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        try:
            return self._rx.get(timeout=timeout), False
        except queue.Empty:
            return None, False

    def shutdown(self) -> None:
        super().shutdown()
        self._stop.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        self.pty.close()

    # -- the host's side ----------------------------------------------------------------------
    def _reply(self, data: bytes) -> None:
        with self._lock:
            self.pty.write(data)

    def _serve(self) -> None:
        buf = bytearray()
        while not self._stop.is_set():
            try:
                buf += self.pty.read(timeout=0.02)
            except (TransportError, OSError, ValueError):  # the pty was closed under us
                return
            while True:
                end = buf.find(b"\r")
                if end < 0:
                    break
                command = bytes(buf[:end]).replace(b"\n", b"").decode("ascii", "replace")
                del buf[:end + 1]
                answer = self._command(command)
                if answer == ERROR:
                    self.errors += 1
                try:
                    self._reply(answer)
                except (TransportError, OSError, ValueError):  # host gone or not reading
                    self.errors += 1

    def _command(self, cmd: str) -> bytes:
        self.commands.append(cmd)
        head, arg = cmd[:1], cmd[1:]
        is_open = self._opened.is_set()
        if head == "":
            return OK
        if head in _FRAME_KINDS:
            if not is_open or self.listen_only:
                return ERROR
            try:
                msg = decode_slcan(cmd)
            except DecodeError:
                return ERROR
            self._rx.put(msg)
            self.from_host += 1
            return (b"Z" if msg.is_extended_id else b"z") + OK
        if head in "OL":
            if is_open or arg:
                return ERROR
            self.listen_only = head == "L"
            self._opened.set()
            return OK
        if head == "C":
            if not is_open:
                return ERROR
            self._opened.clear()
            return OK
        if head == "S" and arg.isdigit() and int(arg) in BITRATES:
            if is_open:
                return ERROR
            self.bitrate = BITRATES[int(arg)]
            return OK
        if head == "Z" and arg in ("0", "1"):
            self.timestamps = arg == "1"
            return OK
        if (head == "s" and len(arg) == 4) or (head == "Y" and arg in ("2", "5")) or (
                head in "Mm" and len(arg) == 8):
            return ERROR if is_open else OK
        if head == "V" and not arg:
            return f"V{self.version}".encode() + OK
        if head == "v" and not arg:
            return b"v" + self.version.encode() + OK
        if head == "N" and not arg:
            return f"N{self.serial_number}".encode() + OK
        if head == "F" and not arg:
            return b"F00" + OK
        return ERROR
