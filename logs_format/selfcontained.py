"""Self-contained chunks: every chunk the writer closes starts with the schema and channel records so far.

The ``mcap`` writer puts a channel's definition only into the chunk where the channel first appears
(and into the summary, written at close). A log that was cut off has no summary; if its first chunk
is then damaged, every later message would name a channel nobody defined, and the reader could only
count them as orphans. With the definitions repeated at the start of each chunk (a few hundred bytes
per chunk of megabytes; the MCAP spec allows identical repeats), any chunk read alone names its
channels, so damage costs only the chunks it hits.

mcap's public API has no way to add records to a chunk or to learn when one closes (``register_channel`` and
``register_schema`` make new ids), so the writer's private chunk builder (``Writer._Writer__chunk_builder``, a
``mcap._chunk_builder.ChunkBuilder``) is replaced. ``pyproject.toml`` pins mcap to the versions tested with it
(:data:`TESTED_MCAP`); :func:`repeat_definitions` raises :class:`~logs_format.profile.LogError` naming the attribute
and the installed version when a writer does not have it, and ``tests/test_log_mcap_private.py`` fails the same way.
"""

from __future__ import annotations

from importlib.metadata import version

from mcap._chunk_builder import ChunkBuilder
from mcap.records import Channel, Schema
from mcap.writer import Writer

from logs_format.profile import LogError

#: the mcap versions the private builder was tested with: the dependency's range in pyproject.toml
TESTED_MCAP = ">=1.2,<1.7"
#: the writer's private chunk builder, name-mangled (``self.__chunk_builder`` in ``mcap.writer.Writer.__init__``)
CHUNK_BUILDER_ATTR = "_Writer__chunk_builder"


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
    chunks. A writer without chunking is left as it is. Raises :class:`LogError` when the installed mcap's writer
    has no :data:`CHUNK_BUILDER_ATTR` holding a ``ChunkBuilder`` (a version outside :data:`TESTED_MCAP`)."""
    if not hasattr(writer, CHUNK_BUILDER_ATTR):
        raise LogError(f"mcap {version('mcap')}: mcap.writer.Writer has no attribute {CHUNK_BUILDER_ATTR}, which "
                       f"logs_format.selfcontained replaces; install mcap{TESTED_MCAP} (tested) or adapt it")
    builder = getattr(writer, CHUNK_BUILDER_ATTR)
    if builder is None:
        return
    if type(builder) is not ChunkBuilder:
        raise LogError(f"mcap {version('mcap')}: Writer.{CHUNK_BUILDER_ATTR} is a {type(builder).__name__}, not "
                       f"mcap._chunk_builder.ChunkBuilder; install mcap{TESTED_MCAP} (tested) or adapt "
                       "logs_format.selfcontained")
    setattr(writer, CHUNK_BUILDER_ATTR, SelfContainedChunkBuilder())
