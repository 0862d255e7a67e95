"""What a raw channel of a mission log is: the schema record that names its wire format and its spec.

Each raw channel of a log written by auvlink 0.1 or later carries a schema:

* name ``auvlink.<encoding>`` (``auvlink.rdi.pd0``, ``auvlink.soundmetrics.didson``, ...);
* encoding the wire format's own name, the channel's message encoding (``rdi.pd0``): the message
  bytes are one frame exactly as the device sent it, not a serialization of the schema;
* data a small JSON descriptor (UTF-8)::

    {"auvlink_schema": 1, "format": "pd0", "encoding": "rdi.pd0",
     "description": "Teledyne RDI PD0 binary ensembles (DVL / ADCP)",
     "spec": {"title": "Teledyne RD Instruments, WorkHorse Commands and Output Data Format ...",
              "url": "https://..."},
     "record": "auvlink.codecs.pd0_records.Pd0Ensemble",
     "decoder": "logs_format.decoder.DecoderFactory", "message": "one raw wire frame per message"}

The ``url`` is the publisher's page for the document (vendor manuals sit behind a download page;
the title names the exact document). ``record`` is the Python type the codec decodes a frame to;
:class:`logs_format.decoder.DecoderFactory` gives ``mcap`` readers that decode.

Logs written before carry an empty schema (name = the encoding, no data); the decoder factory
still decodes them by the channel's message encoding.
"""

from __future__ import annotations

import json
import types
import typing
from dataclasses import dataclass
from typing import Any

from auvlink import formats
from auvlink.errors import UnknownFormatError
from logs_format.bounded_json import loads_bounded

#: prefix of the schema names of raw channels
SCHEMA_PREFIX = "auvlink."
#: version of the descriptor layout (``auvlink_schema`` key)
DESCRIPTOR_VERSION = 1
DECODER = "logs_format.decoder.DecoderFactory"


@dataclass(frozen=True)
class Spec:
    """The document a wire format follows: its title and where its publisher offers it."""

    title: str
    url: str


_RDI = Spec("Teledyne RD Instruments, \"WorkHorse Commands and Output Data Format\" (P/N 957-6156-00)",
            "https://www.teledynemarine.com/brands/rdi")
_ARIS = Spec("Sound Metrics, ARIS file and frame header definitions (aris-file-sdk, type-definitions/C)",
             "https://github.com/SoundMetrics/aris-file-sdk")

#: spec of each built-in wire format (by format name)
SPECS: dict[str, Spec] = {
    "pd0": _RDI,
    "pd6": Spec(_RDI.title + ", chapter \"DVL Output Data Format (PD6)\"", _RDI.url),
    "dsp1760": Spec("KVH Industries, DSP-1760 Fiber Optic Gyro technical manual, \"message format\"",
                    "https://www.kvh.com"),
    "dsp3000": Spec("KVH Industries, DSP-3000 Fiber Optic Gyro technical manual, ASCII output",
                    "https://www.kvh.com"),
    "keller": Spec("KELLER AG, \"Communication protocol for KELLER Series 30 (bus)\"",
                   "https://keller-pressure.com/en/products/software/communication-protocols"),
    "paro": Spec("Paroscientific, \"Digiquartz Programming and Operation Manual\" (document 8107-001)",
                 "https://paroscientific.com/manuals/"),
    "aris": _ARIS,
    "didson": Spec(_ARIS.title + "; DIDSON-class live frames: 96 beams x 512 samples after the ARIS header",
                   _ARIS.url),
    "nmea": Spec("National Marine Electronics Association, \"NMEA 0183 Interface Standard\" (GGA, RMC, ZDA sentences)",
                 "https://www.nmea.org/nmea-0183.html"),
    "can": Spec("auvlink navigation CAN database (Vector DBC), auvlink/data/auvlink_nav.dbc",
                "https://github.com/cantools/cantools"),
}


def spec_of(format_name: str) -> Spec | None:
    """The spec of a format (its base name: ``dsp3000_incremental`` -> ``dsp3000``), or None."""
    if format_name in SPECS:
        return SPECS[format_name]
    base = format_name.split("_", 1)[0]
    return SPECS.get(base)


def record_type(fmt: formats.WireFormat) -> str:
    """Qualified name of the type ``fmt.decode`` returns (``A | B`` for a union; the codec module
    where the hint is missing)."""
    decode = getattr(fmt.decode, "func", fmt.decode)  # a functools.partial: the function under it
    try:
        ret = typing.get_type_hints(decode).get("return")
    except Exception:  # hints naming what the module does not import at run time
        ret = None
    options = typing.get_args(ret) if typing.get_origin(ret) in (typing.Union, types.UnionType) else (ret,)
    if options and all(isinstance(t, type) for t in options):
        return " | ".join(f"{t.__module__}.{t.__qualname__}" for t in options)
    return str(getattr(decode, "__module__", "") or fmt.name)


def schema_name(encoding: str) -> str:
    """``rdi.pd0`` -> ``auvlink.rdi.pd0``."""
    return SCHEMA_PREFIX + encoding


def descriptor(format_name: str) -> dict[str, Any]:
    """The JSON descriptor of a wire format (see the module docstring); a format this install does
    not know gets one naming it only."""
    out: dict[str, Any] = {"auvlink_schema": DESCRIPTOR_VERSION, "format": format_name}
    try:
        fmt = formats.get(format_name)
    except (UnknownFormatError, ImportError):
        out.update(encoding=format_name, message="one raw wire frame per message")
        return out
    spec = spec_of(format_name)
    out.update(encoding=fmt.encoding, description=fmt.description,
               spec={"title": spec.title, "url": spec.url} if spec else None,
               record=record_type(fmt), decoder=DECODER, message="one raw wire frame per message")
    return out


def schema_record(format_name: str, encoding: str) -> tuple[str, str, bytes]:
    """``(name, encoding, data)`` of the schema record of a raw channel."""
    data = json.dumps(descriptor(format_name), sort_keys=True, separators=(",", ":")).encode()
    return schema_name(encoding), encoding, data


def parse_descriptor(data: bytes) -> dict[str, Any] | None:
    """The descriptor in a raw channel's schema data, or None (an old log's empty schema, other data)."""
    if not data:
        return None
    try:
        out = loads_bounded(bytes(data).decode("utf-8"))
    except (UnicodeDecodeError, ValueError):
        return None
    return out if isinstance(out, dict) and "format" in out else None
