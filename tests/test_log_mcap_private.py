"""mcap's private chunk builder, which :mod:`logs_format.selfcontained` replaces: the installed mcap is a tested
version, the attribute is there, every chunk a log writer closes names its schemas and channels, and a writer
without the attribute is refused with the attribute and the installed version named."""

from __future__ import annotations

import io
import tomllib
from importlib.metadata import version
from pathlib import Path
from typing import Any, cast

import pytest
from mcap._chunk_builder import ChunkBuilder
from mcap.records import Channel, Chunk, Message, Schema
from mcap.stream_reader import StreamReader, breakup_chunk
from mcap.writer import CompressionType, Writer
from packaging.requirements import Requirement

from logs_format.profile import LogError
from logs_format.selfcontained import CHUNK_BUILDER_ATTR, TESTED_MCAP, SelfContainedChunkBuilder, repeat_definitions

PYPROJECT = Path(__file__).resolve().parents[1] / "pyproject.toml"


def test_the_installed_mcap_is_a_tested_version() -> None:
    deps = tomllib.loads(PYPROJECT.read_text())["project"]["dependencies"]
    req = next(Requirement(d) for d in deps if Requirement(d).name == "mcap")
    assert str(req.specifier) == str(Requirement(f"mcap{TESTED_MCAP}").specifier), \
        "pyproject's mcap range and logs_format.selfcontained.TESTED_MCAP differ"
    assert req.specifier.contains(version("mcap")), \
        f"mcap {version('mcap')} is outside the tested range {req.specifier} (logs_format.selfcontained)"


def test_the_writer_has_the_private_chunk_builder() -> None:
    writer = Writer(io.BytesIO())
    builder = getattr(writer, CHUNK_BUILDER_ATTR, None)
    assert type(builder) is ChunkBuilder, (
        f"mcap {version('mcap')}: Writer.{CHUNK_BUILDER_ATTR} is {type(builder).__name__}, not "
        "mcap._chunk_builder.ChunkBuilder: logs_format.selfcontained must be adapted")
    for name in ("add_schema", "add_channel", "reset", "record_writer"):
        assert hasattr(builder, name), f"mcap {version('mcap')}: ChunkBuilder has no {name}"


def chunks_of(data: bytes) -> list[list[Any]]:
    """The records inside each chunk of an MCAP file, chunk by chunk."""
    return [breakup_chunk(r) for r in StreamReader(io.BytesIO(data), emit_chunks=True).records
            if isinstance(r, Chunk)]


def test_every_chunk_names_the_schemas_and_channels_registered_before_it() -> None:
    out = io.BytesIO()
    writer = Writer(out, chunk_size=2048, compression=CompressionType.NONE)
    repeat_definitions(writer)
    assert isinstance(getattr(writer, CHUNK_BUILDER_ATTR), SelfContainedChunkBuilder)
    writer.start()
    schema = writer.register_schema("s", "jsonschema", b"{}")
    first = writer.register_channel("/a", "json", schema)
    for t in range(200):
        writer.add_message(first, t, b'{"v": %d}' % t, t)
    second = writer.register_channel("/b", "json", schema)
    for t in range(200, 400):
        writer.add_message(first if t % 2 else second, t, b'{"v": %d}' % t, t)
    writer.finish()
    chunks = chunks_of(out.getvalue())
    assert len(chunks) > 5
    for records in chunks:  # read alone, each chunk defines a message's channel and its schema before it
        schemas: set[int] = set()
        channels: set[int] = set()
        for r in records:
            if isinstance(r, Schema):
                schemas.add(r.id)
            elif isinstance(r, Channel):
                assert r.schema_id in schemas
                channels.add(r.id)
            else:
                assert isinstance(r, Message) and r.channel_id in channels
    assert {r.id for r in chunks[-1] if isinstance(r, Channel)} == {first, second}
    assert [r.id for r in chunks[-1] if isinstance(r, Channel | Schema)] == [schema, first, second]


def test_a_writer_without_chunking_is_left_as_it_is() -> None:
    writer = Writer(io.BytesIO(), use_chunking=False)
    repeat_definitions(writer)
    assert getattr(writer, CHUNK_BUILDER_ATTR) is None


def test_a_writer_without_the_private_attribute_is_refused_naming_it_and_the_version() -> None:
    class OtherWriter:  # a writer as a future mcap may build it: no name-mangled chunk builder
        pass

    with pytest.raises(LogError) as err:
        repeat_definitions(cast(Writer, OtherWriter()))
    assert CHUNK_BUILDER_ATTR in str(err.value) and f"mcap {version('mcap')}" in str(err.value)
