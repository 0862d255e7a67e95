"""An ``mcap`` decoder factory for mission logs: ``iter_decoded_messages`` yields auvlink records.

    from mcap.reader import make_reader
    from logs_format.decoder import DecoderFactory

    with open("mission.mcap", "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, message, record in reader.iter_decoded_messages():
            ...  # record: e.g. a Pd0Ensemble for the "dvl" channel, a DidsonFrame for "sonar"

Raw channels decode with the codec of their wire format (the same pure ``decode(bytes)`` the
drivers use), chosen from the schema's descriptor (:mod:`logs_format.specs`: the exact format,
e.g. ``dsp3000_incremental``) or, for logs of earlier versions whose raw channels have an empty
schema, from the channel's message encoding (``rdi.pd0`` -> ``pd0``). JSON channels (``json``:
poses, detections, events) decode to dicts. A frame that does not decode raises the codec's
:class:`~auvlink.errors.DecodeError` from the decoder, as it would from a driver; with
``errors="keep"`` the decoder gives an :class:`UndecodedFrame` instead (the error and the bytes), so a
log that recorded garbage (a live log keeps every frame, decodable or not) reads to its end.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

from mcap.decoder import DecoderFactory as McapDecoderFactory
from mcap.records import Schema

from auvlink import formats
from auvlink.errors import DecodeError, UnknownFormatError
from logs_format.bounded_json import loads_bounded
from logs_format.profile import JSON_MESSAGE_ENCODING
from logs_format.specs import parse_descriptor


def _json(data: bytes) -> Any:
    return loads_bounded(data)  # a ValueError over the size or depth limit (logs_format.bounded_json)


@dataclass(frozen=True)
class UndecodedFrame:
    """A raw frame its codec refused (``DecoderFactory(errors="keep")``): the format, why, the bytes."""

    format: str
    error: str
    data: bytes


def _keeping(fmt: formats.WireFormat) -> Callable[[bytes], Any]:
    def decode(data: bytes) -> Any:
        try:
            return fmt.decode(data)
        except DecodeError as exc:
            return UndecodedFrame(fmt.name, str(exc), bytes(data))

    return decode


def wire_format_of(message_encoding: str, schema: Schema | None) -> formats.WireFormat | None:
    """The wire format of a raw channel (schema descriptor first, then the message encoding), or None."""
    desc = parse_descriptor(schema.data) if schema is not None else None
    if desc is not None:
        try:
            fmt = formats.get(str(desc["format"]))
        except (UnknownFormatError, ImportError):
            fmt = None
        if fmt is not None and fmt.encoding == message_encoding:
            return fmt
    try:
        return formats.by_encoding(message_encoding)
    except (UnknownFormatError, ImportError):
        return None


class DecoderFactory(McapDecoderFactory):
    """Decoders for the channels of an auvlink mission log (see the module docstring); ``json=False``
    leaves JSON channels to another factory; ``errors`` ``"raise"`` (the default) or ``"keep"``."""

    def __init__(self, *, json: bool = True, errors: Literal["raise", "keep"] = "raise") -> None:
        if errors not in ("raise", "keep"):
            raise ValueError(f"errors must be 'raise' or 'keep', got {errors!r}")
        self.json = json
        self.errors = errors

    def decoder_for(self, message_encoding: str, schema: Schema | None) -> Callable[[bytes], Any] | None:
        if message_encoding == JSON_MESSAGE_ENCODING:
            return _json if self.json else None
        fmt = wire_format_of(message_encoding, schema)
        if fmt is None:
            return None
        return _keeping(fmt) if self.errors == "keep" else fmt.decode
