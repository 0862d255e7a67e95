"""The auvlink MCAP profile: how a mission log names its channels, schemas, metadata and attachments.

Container: MCAP (https://mcap.dev/spec), written and read with the ``mcap`` package.

* One channel per device: topic = device name (``"dvl"``), message encoding = the wire format's
  encoding (``"rdi.pd0"``); schema name ``auvlink.<encoding>`` (``"auvlink.rdi.pd0"``), schema
  encoding = the message encoding, schema data a JSON descriptor naming the format, its spec (title
  and URL) and the auvlink record type (:mod:`logs_format.specs`; the bytes are the vendor's own
  wire format). Logs of earlier versions have an empty schema (name = the encoding, no data).
  ``mcap`` readers decode these channels with :class:`logs_format.decoder.DecoderFactory`.
  Channel metadata: ``format`` (the auvlink format name, ``"pd0"``) and ``device``.
* Message = one raw wire frame exactly as received; ``log_time`` = host receive time (UTC ns),
  ``publish_time`` = sensor time when the writer knew it, else equal to ``log_time`` (MCAP usage);
  ``sequence`` counts the frames of the channel from 0.
* Decoded channels (poses, detections) are JSON: message encoding ``json``, schema encoding
  ``jsonschema`` (see :mod:`logs_format.schemas`).
* Metadata records: ``vehicle_config``, ``software``, ``ground_truth``. MCAP metadata values are
  strings; structured values are stored as JSON text.
* Attachments: meshes of the ground truth objects (``model/stl``, ``model/obj``, ``model/ply``).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

from mcap.writer import CompressionType

from auvlink.errors import AuvlinkError
from logs_format.bounded_json import JsonLimitError, loads_bounded

#: MCAP header ``profile`` field of auvlink logs
PROFILE = "auvlink"

#: metadata record names
META_VEHICLE_CONFIG = "vehicle_config"
META_SOFTWARE = "software"
META_GROUND_TRUTH = "ground_truth"

#: channel metadata keys
CH_FORMAT = "format"
CH_DEVICE = "device"

#: encodings of decoded (JSON) channels
JSON_MESSAGE_ENCODING = "json"
JSON_SCHEMA_ENCODING = "jsonschema"

#: media types of mesh attachments by file suffix
MESH_MEDIA_TYPES = {
    ".stl": "model/stl", ".obj": "model/obj", ".ply": "model/ply", ".glb": "model/gltf-binary",
}

COMPRESSIONS: dict[str, CompressionType] = {
    "zstd": CompressionType.ZSTD,
    "lz4": CompressionType.LZ4,
    "none": CompressionType.NONE,
}


class LogError(AuvlinkError):
    """A mission log cannot be written or is not a mission log at all (never raised for truncation)."""


def compression_type(name: str) -> CompressionType:
    """``"zstd"``, ``"lz4"`` or ``"none"`` -> the mcap enum."""
    try:
        return COMPRESSIONS[name.lower()]
    except KeyError as exc:
        raise LogError(f"unknown compression {name!r}; use one of {', '.join(COMPRESSIONS)}") from exc


def wire_channel(device: str, format_name: str, encoding: str) -> tuple[str, str, dict[str, str]]:
    """Topic, message encoding and channel metadata of a raw wire-format channel."""
    return device, encoding, {CH_FORMAT: format_name, CH_DEVICE: device}


def metadata_strings(data: Mapping[str, Any]) -> dict[str, str]:
    """MCAP metadata is ``map<string, string>``: keep strings, store anything else as JSON text."""
    out: dict[str, str] = {}
    for key, value in data.items():
        out[str(key)] = value if isinstance(value, str) else json.dumps(value, sort_keys=True, default=str)
    return out


def metadata_values(data: Mapping[str, str], problems: list[str] | None = None, name: str = "") -> dict[str, Any]:
    """Inverse of :func:`metadata_strings` where a value parses as JSON (else the string).

    A value over the JSON limits of :mod:`logs_format.bounded_json` (size, nesting depth) becomes None,
    and one line naming ``name.key`` and the limit goes to ``problems`` (when given)."""
    out: dict[str, Any] = {}
    for key, value in data.items():
        try:
            out[key] = loads_bounded(value)
        except JsonLimitError as exc:
            out[key] = None
            if problems is not None:
                problems.append(f"metadata {name + '.' if name else ''}{key}: {exc}; ignored")
        except ValueError:
            out[key] = value
    return out
