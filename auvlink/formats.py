"""The open registry of wire formats: a name -> codec pair + framer, imported only when used.

Each codec module defines ``WIRE_FORMAT = WireFormat(...)`` (a registry entry ``"module:NAME"``
picks another attribute, e.g. the DSP-3000's angle-mode variants). Third parties add formats with
:func:`register` or through the ``auvlink.formats`` entry-point group (``name = "pkg.module"``).

=========  =================  ==============================================================
name       encoding (MCAP)    what
=========  =================  ==============================================================
pd0        rdi.pd0            Teledyne RDI PD0 binary ensembles (DVL / ADCP)
pd6        rdi.pd6            Teledyne RDI PD6 ASCII navigation lines
dsp1760    kvh.dsp1760        KVH DSP-1750/1760 36-byte binary FOG messages
dsp3000    kvh.dsp3000        KVH DSP-3000 ASCII FOG lines (rate; ``_incremental``, ``_integrated``)
keller     keller.bus         Keller bus (F48 / F73) request and response frames
paro       paro.digiquartz    Paroscientific Digiquartz ASCII ``*0001...`` lines
aris       soundmetrics.aris  Sound Metrics ARIS frames (1024-byte header + image)
didson     soundmetrics.didson  DIDSON-class live frames (96 beams x 512 samples, ARIS header)
can        can.dbc            CAN frames of the auvlink navigation DBC (cantools)
nmea       nmea.0183          NMEA 0183 GNSS sentences (GGA, RMC, ZDA) via pynmea2
oculus     blueprint.oculus   Blueprint Subsea Oculus sonar messages (SimplePingResult V1/V2, SimpleFire, status)
=========  =================  ==============================================================
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from importlib.metadata import entry_points
from typing import Any

from auvlink.errors import UnknownFormatError
from auvlink.framing.base import Framer


@dataclass(frozen=True)
class WireFormat:
    """Everything the drivers and the log need to know about one wire format."""

    name: str
    encoding: str  # MCAP schema/message encoding name, e.g. "rdi.pd0"
    description: str
    decode: Callable[[bytes], Any]
    encode: Callable[[Any], bytes]
    framer: Callable[[], Framer]
    #: sensor time of a decoded record in s since the UNIX epoch, or None when it has none
    sensor_time: Callable[[Any], float | None] = lambda record: None
    #: a record -> JSON-ready dict (SI units) for ``auvlink decode --jsonl`` and exports
    to_json: Callable[[Any], dict[str, Any]] | None = None
    #: file-level reader for formats whose files are not a plain frame stream (ARIS file header)
    read_file: Callable[[bytes], Any] | None = None


_MODULES: dict[str, str] = {
    "pd0": "auvlink.codecs.pd0",
    "pd6": "auvlink.codecs.pd6",
    "dsp1760": "auvlink.codecs.dsp1760",
    "dsp3000": "auvlink.codecs.dsp3000",
    "dsp3000_incremental": "auvlink.codecs.dsp3000:WIRE_FORMAT_INCREMENTAL",
    "dsp3000_integrated": "auvlink.codecs.dsp3000:WIRE_FORMAT_INTEGRATED",
    "keller": "auvlink.codecs.keller",
    "paro": "auvlink.codecs.paro",
    "aris": "auvlink.codecs.aris",
    "didson": "auvlink.codecs.didson",
    "can": "auvlink.codecs.can_nav",
    "nmea": "auvlink.codecs.nmea",
    "oculus": "auvlink.codecs.oculus",
}
_LOADED: dict[str, WireFormat] = {}


def register(fmt: WireFormat) -> None:
    """Add (or replace) a wire format at run time."""
    _LOADED[fmt.name] = fmt
    _MODULES.setdefault(fmt.name, "")


def names() -> list[str]:
    """All registered format names (built-in and entry points)."""
    extra = [ep.name for ep in entry_points(group="auvlink.formats")]
    return sorted(set(_MODULES) | set(extra))


def get(name: str) -> WireFormat:
    """The :class:`WireFormat` called ``name`` (importing its module on first use)."""
    if name in _LOADED:
        return _LOADED[name]
    module_path = _MODULES.get(name)
    if module_path is None:
        for ep in entry_points(group="auvlink.formats"):
            if ep.name == name:
                module_path = ep.value
                break
    if not module_path:
        raise UnknownFormatError(f"unknown wire format {name!r}; known: {', '.join(names())}")
    module_name, _, attr = module_path.partition(":")
    module = importlib.import_module(module_name)
    fmt: WireFormat = getattr(module, attr or "WIRE_FORMAT")
    _LOADED[name] = fmt
    return fmt


def by_encoding(encoding: str) -> WireFormat:
    """The format whose MCAP encoding name is ``encoding`` (e.g. ``"rdi.pd0"``)."""
    for name in names():
        fmt = get(name)
        if fmt.encoding == encoding:
            return fmt
    raise UnknownFormatError(f"no wire format has the encoding {encoding!r}")
