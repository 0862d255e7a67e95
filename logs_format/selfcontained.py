"""Self-contained chunks: every chunk the writer closes starts with the schema and channel records so far.

The ``mcap`` writer puts a channel's definition only into the chunk where the channel first appears
(and into the summary, written at close). A log that was cut off has no summary; if its first chunk
is then damaged, every later message would name a channel nobody defined, and the reader could only
count them as orphans. With the definitions repeated at the start of each chunk (a few hundred bytes
per chunk of megabytes; the MCAP spec allows identical repeats), any chunk read alone names its
channels, so damage costs only the chunks it hits.
"""

from __future__ import annotations

from mcap._chunk_builder import ChunkBuilder
from mcap.records import Channel, Schema
from mcap.writer import Writer


class SelfContainedChunkBuilder(ChunkBuilder):
    """A :class:`mcap._chunk_builder.ChunkBuilder` that re-adds every schema and channel after a reset."""

    def __init__(self) -> None:
        super().__init__()
        self._definitions: list[Schema | Channel] = []

    def add_schema(self, schema: Schema) -> None:
        self._definitions.append(schema)
        super().add_schema(schema)

    def add_channel(self, channel: Channel) -> None:
        self._definitions.append(channel)
        super().add_channel(channel)

    def reset(self) -> None:
        super().reset()
        for record in self._definitions:
            record.write(self.record_writer)


def repeat_definitions(writer: Writer) -> None:
    """Make ``writer`` (a chunking ``mcap`` writer, before anything is registered) write self-contained
    chunks. A writer without chunking is left as it is."""
    attr = "_Writer__chunk_builder"  # the writer's private builder: mcap has no option for this
    if getattr(writer, attr, None) is not None:
        setattr(writer, attr, SelfContainedChunkBuilder())
