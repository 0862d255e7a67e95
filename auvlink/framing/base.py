"""The framer contract: ``feed(bytes) -> list[bytes]`` of whole frames, for any chunking.

A framer keeps an internal buffer. Whatever cannot start a frame is dropped and counted;
a frame whose checksum fails is counted and the search resumes one byte after its start,
so a valid frame hidden inside garbage (or overlapping a damaged one) is never lost.
``flush()`` is called at end of stream: a partial frame left in the buffer counts as truncated.

Fast path: when nothing is buffered, :meth:`Framer.feed` first asks the format's :meth:`Framer._whole`
whether ``data`` is exactly one whole, valid frame (the common case when a log replays one frame per
message, and for many packet transports). The answer must be exactly what :meth:`Framer._extract`
would return, the same checks included (CRC, sanity); a framer that does not know returns None and
the general path runs. The frame is then ``data`` itself (no copy).

Bounds: every format has a largest frame (:attr:`Framer.max_frame`, bytes); after any feed at most
that many bytes stay buffered (bytes that cannot start a frame are dropped and counted), and a large
``data`` is framed in slices of :data:`FEED_SLICE` bytes, so a framer's memory does not grow with
its input. Every framer is linear in its input: a scan position is never searched twice per feed.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

#: a feed larger than this is framed in slices of this many bytes (bounds the working memory)
FEED_SLICE = 1 << 20


@dataclass
class FramerStats:
    """Counters of one framer (mutable, owned by that framer instance)."""

    frames: int = 0
    bytes_in: int = 0
    dropped_bytes: int = 0
    bad_checksums: int = 0
    truncated: int = 0
    truncated_bytes: int = 0  # bytes of the partial frame(s) left at the end of the stream (part of dropped_bytes)

    def as_dict(self) -> dict[str, int]:
        return dict(self.__dict__)  # flat ints: a shallow copy (dataclasses.asdict costs ~50 us per frame)


class Framer(ABC):
    """Base class: owns the buffer and the counters; a format implements :meth:`_extract`."""

    #: the format name this framer cuts (``"pd0"``, ``"dsp1760"``, ...)
    format_name: str = ""
    #: the longest frame of the format in bytes: the most a framer keeps buffered between feeds
    max_frame: int = 1 << 16

    def __init__(self) -> None:
        self._buf = bytearray()
        self.stats = FramerStats()

    def feed(self, data: bytes) -> list[bytes]:
        """Add ``data`` and return every whole frame now complete, in stream order."""
        self.stats.bytes_in += len(data)
        if not self._buf:
            whole = self._whole(data)
            if whole is not None:
                self.stats.frames += 1
                return [whole]
        if len(data) <= FEED_SLICE:
            self._buf += data
            frames = self._extract(self._buf)
        else:
            frames = []
            view = memoryview(data)
            for k in range(0, len(data), FEED_SLICE):
                self._buf += view[k : k + FEED_SLICE]
                frames += self._extract(self._buf)
        self.stats.frames += len(frames)
        return frames

    def flush(self) -> list[bytes]:
        """End of stream: return what is still whole and count any partial frame as truncated."""
        frames = self._extract(self._buf, final=True)
        self.stats.frames += len(frames)
        if self._buf:
            self.stats.truncated += 1
            self.stats.truncated_bytes += len(self._buf)
            self.stats.dropped_bytes += len(self._buf)
            self._buf.clear()
        return frames

    def reset(self) -> None:
        """Forget buffered bytes (e.g. after a port was reopened); counters are kept."""
        self._buf.clear()

    @property
    def buffered(self) -> int:
        """Bytes waiting for the rest of a frame."""
        return len(self._buf)

    def _drop(self, buf: bytearray, n: int) -> None:
        """Discard ``n`` bytes from the front of ``buf`` and count them."""
        if n > 0:
            del buf[:n]
            self.stats.dropped_bytes += n

    def _whole(self, data: bytes | bytearray | memoryview) -> bytes | None:
        """``data`` as bytes when it is exactly one valid frame that :meth:`_extract` would return alone
        from an empty buffer, leaving nothing behind and counting nothing; else None. Only asked when
        nothing is buffered. Default: None (always the general path)."""
        return None

    @abstractmethod
    def _extract(self, buf: bytearray, final: bool = False) -> list[bytes]:
        """Remove whole frames (and garbage) from the front of ``buf``; leave a partial frame."""


class ResumingFramer(Framer):
    """A framer that checks a candidate frame for a header inside it (a damaged header can claim the wrong
    length) and remembers between feeds how far that search went: ``_checked``, an offset into the buffer,
    so that every byte is searched once (linear time)."""

    def __init__(self) -> None:
        super().__init__()
        self._checked = 0

    def reset(self) -> None:
        super().reset()
        self._checked = 0

    def _consume(self, buf: bytearray, pos: int) -> None:
        """Remove ``buf[:pos]`` (already returned or counted), keeping ``_checked`` relative to the new front."""
        self._checked = max(0, self._checked - pos)
        del buf[:pos]
