"""Read a mission log: a streaming, time-ordered merge of its channels, robust to truncation.

    with MissionLogReader("mission.mcap") as log:
        for msg in log.messages(channels=["dvl", "gyro"], start_ns=t0, end_ns=t1):
            ...
        print(log.loss.describe())

The file is indexed by :func:`logs_format.scan.scan` (record headers, resynchronised after damage;
the summary's chunk index when the summary checks out), so a damaged or cut-off log yields every
message of its intact chunks and reports the rest in :attr:`MissionLogReader.loss` (a
:class:`~logs_format.loss.LossReport`); nothing raises for damage. Chunks are opened lazily in the
order of their first log time and merged with a heap, so memory holds only the chunks that
overlap in time (one or two), whatever the size of the log. While one chunk is consumed, the next
is read and decompressed in a background thread (``prefetch=False`` turns that off).
"""

from __future__ import annotations

import bisect
import heapq
import os
from collections.abc import Iterable, Iterator
from operator import itemgetter
from pathlib import Path
from types import TracebackType
from typing import Any

from mcap.records import Attachment, Channel, Schema

from logs_format.chunks import BadChunk, ChannelInfo, ChunkOpener, LogMessage
from logs_format.loss import DAMAGED_CHUNK, LossReport, LostSpan
from logs_format.profile import LogError, metadata_values
from logs_format.scan import AttachmentRef, ChunkRef, scan

_Msg = tuple[int, int, int, int, bytes]  # log_time, publish_time, sequence, channel_id, data
_time = itemgetter(0)


class MissionLogReader:
    """A mission log opened for reading (a context manager; not thread-safe)."""

    def __init__(self, path: str | Path, *, prefetch: bool = True) -> None:
        self.path = Path(path)
        #: read and decompress the next chunk in a background thread while this one is consumed
        self.prefetch = prefetch
        try:
            self._f = open(self.path, "rb")
        except OSError as exc:
            raise LogError(f"cannot open log {self.path}: {exc.strerror or exc}") from exc
        try:
            self.index = scan(self._f, os.fstat(self._f.fileno()).st_size)
        except BaseException:
            self._f.close()
            raise
        self._opener = ChunkOpener(self._f)
        self._schemas: dict[int, Schema] = dict(self.index.schemas)
        self._channels: dict[int, ChannelInfo] = {}
        for ch in self.index.channels.values():
            self._add_channel(ch)
        self._bad: set[int] = set()  # offsets of chunks found damaged (each reported once)
        self._orphans: set[tuple[int, int, int]] = set()  # (chunk offset, log time, sequence)
        #: metadata values refused by the last ``metadata(decode_json=True)`` (one line each: key and limit)
        self.metadata_problems: list[str] = []

    # -- life cycle -----------------------------------------------------------------------
    def close(self) -> None:
        self._opener.close()
        self._f.close()

    def __enter__(self) -> MissionLogReader:
        return self

    def __exit__(
        self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    # -- what the index knows -------------------------------------------------------------
    @property
    def loss(self) -> LossReport:
        """What is lost (truncation from the scan; damaged chunks as they are met while reading)."""
        return self.index.loss

    @property
    def complete(self) -> bool:
        return self.index.loss.complete

    @property
    def chunks(self) -> list[ChunkRef]:
        return self.index.chunks

    @property
    def start_ns(self) -> int | None:
        return min((c.start_ns for c in self.index.chunks), default=None)

    @property
    def end_ns(self) -> int | None:
        return max((c.end_ns for c in self.index.chunks), default=None)

    @property
    def duration_s(self) -> float:
        start, end = self.start_ns, self.end_ns
        return 0.0 if start is None or end is None else (end - start) * 1e-9

    @property
    def channels(self) -> dict[str, ChannelInfo]:
        """Channels by topic known so far (all of them in a complete log; in a cut-off log, those
        met while reading; :meth:`discover_channels` opens every chunk to find them all)."""
        return {ch.topic: ch for ch in self._channels.values()}

    def discover_channels(self) -> dict[str, ChannelInfo]:
        if not self.index.channels:
            for ref in self.index.chunks:
                self._load(ref)
        return self.channels

    def metadata(self, decode_json: bool = False) -> dict[str, dict[str, Any]]:
        """Metadata records by name (a later record of the same name wins). With ``decode_json`` a value over the
        JSON limits (:mod:`logs_format.bounded_json`) is None and :attr:`metadata_problems` says why, one line each."""
        out: dict[str, dict[str, Any]] = {}
        problems: list[str] = []
        for name, data in self.index.metadata:
            out[name] = metadata_values(data, problems, name) if decode_json else dict(data)
        if decode_json:
            self.metadata_problems = problems
        return out

    def attachments(self) -> list[AttachmentRef]:
        return list(self.index.attachments)

    def read_attachment(self, ref: AttachmentRef | str) -> bytes:
        """The bytes of an attachment (by reference or by name)."""
        if isinstance(ref, str):
            found = [a for a in self.index.attachments if a.name == ref]
            if not found:
                raise LogError(f"no attachment named {ref!r} in {self.path}")
            ref = found[-1]
        from io import BytesIO

        from mcap.data_stream import ReadDataStream

        self._f.seek(ref.offset + 9)
        return bytes(Attachment.read(ReadDataStream(BytesIO(self._f.read(ref.length - 9)))).data)

    # -- messages -------------------------------------------------------------------------
    def _add_channel(self, ch: Channel) -> None:
        schema = self._schemas.get(ch.schema_id)
        self._channels[ch.id] = ChannelInfo(
            ch.id, ch.topic, ch.message_encoding,
            schema.name if schema else "", schema.encoding if schema else "", dict(ch.metadata),
        )

    def _load(self, ref: ChunkRef) -> list[_Msg]:
        try:
            schemas, channels, messages = self._opener.open(ref)
        except BadChunk as exc:
            if ref.offset not in self._bad:
                self._bad.add(ref.offset)
                run = self.index.chunk_messages.get(ref.offset)
                self.loss.add(LostSpan(DAMAGED_CHUNK, ref.offset, ref.end - ref.offset, ref.start_ns, ref.end_ns,
                                       None if run is None else run.count, f"damaged chunk: {exc}"))
                self.loss.last_time_ns = max(
                    (c.end_ns for c in self.index.chunks if c.offset not in self._bad), default=None)
            return []
        for s in schemas:
            self._schemas[s.id] = s
        for c in channels:  # a chunk's own definitions are CRC-checked: they win over top-level ones
            self._add_channel(c)
        return messages

    def _wanted(self, names: set[str] | None) -> set[int] | None:
        if names is None:
            return None
        return {cid for cid, ch in self._channels.items() if ch.topic in names or ch.device in names}

    def messages(
        self,
        channels: Iterable[str] | None = None,
        start_ns: int | None = None,
        end_ns: int | None = None,
    ) -> Iterator[LogMessage]:
        """Messages in log-time order (ties: the order written), optionally only some channels (topic or
        device names) and ``start_ns <= log_time < end_ns``."""
        names = None if channels is None else set(channels)
        lo = 0 if start_ns is None else start_ns
        hi = (1 << 64) if end_ns is None else end_ns
        refs = sorted(
            (r for r in self.index.chunks if r.end_ns >= lo and r.start_ns < hi),
            key=lambda r: (r.start_ns, r.offset),
        )
        # (log_time, chunk file offset, position, chunk order) of each open chunk: ties keep file order
        heap: list[tuple[int, int, int, int]] = []
        open_chunks: dict[int, list[_Msg]] = {}
        i = 0

        def load(k: int) -> None:
            msgs = self._load(refs[k])
            wanted = self._wanted(names)
            msgs = [m for m in msgs if lo <= m[0] < hi and (wanted is None or m[3] in wanted
                                                             or m[3] not in self._channels)]
            if msgs:
                msgs.sort(key=_time)  # stable: file order within equal times
                open_chunks[k] = msgs
                heapq.heappush(heap, (msgs[0][0], refs[k].offset, 0, k))

        never = 1 << 64
        channel_of = self._channels.get
        # per channel id: (topic, format), or None when the filter leaves it out (looked up once)
        routes: dict[int, tuple[str, str | None] | None] = {}
        while True:
            while i < len(refs) and (not heap or refs[i].start_ns <= heap[0][0]):
                load(i)
                i += 1
            if not heap:
                break
            if i < len(refs) and self.prefetch:
                self._opener.prefetch(refs[i])  # the chunk to be opened next (a no-op when under way)
            _, offset, p, k = heap[0]
            msgs = open_chunks[k]
            # the run of this chunk's messages before anything else can come (the next chunk's
            # start, the heads of the other open chunks) goes out without heap operations
            nxt = refs[i].start_ns if i < len(refs) else never
            if len(heap) > 1:
                nxt = min(nxt, heap[1][0], heap[2][0] if len(heap) > 2 else never)
            stop = max(p + 1, bisect.bisect_left(msgs, nxt, lo=p, key=_time))
            if stop < len(msgs):
                heapq.heapreplace(heap, (msgs[stop][0], offset, stop, k))
            else:
                heapq.heappop(heap)
                del open_chunks[k]
            for j in range(p, stop):
                log_time, pub, seq, cid, data = msgs[j]
                if cid in routes:
                    route = routes[cid]
                else:
                    ch = channel_of(cid)
                    while ch is None and i < len(refs):  # its definition is in a chunk not opened yet
                        load(i)
                        i += 1
                        ch = channel_of(cid)
                    if ch is None:
                        self._orphans.add((refs[k].offset, log_time, seq))
                        self.loss.orphan_messages = len(self._orphans)
                        continue
                    wanted = names is None or ch.topic in names or ch.device in names
                    route = routes[cid] = (ch.topic, ch.format) if wanted else None
                if route is None:
                    continue
                yield LogMessage(route[0], route[1], log_time, pub, seq, data, cid)


def read_messages(
    path: str | Path,
    channels: Iterable[str] | None = None,
    start_ns: int | None = None,
    end_ns: int | None = None,
) -> Iterator[LogMessage]:
    """Messages of the log at ``path`` (see :meth:`MissionLogReader.messages`); closes the file."""
    with MissionLogReader(path) as log:
        yield from log.messages(channels, start_ns, end_ns)
