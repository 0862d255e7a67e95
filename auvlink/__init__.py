"""auvlink: an AUV with a forward-scan imaging sonar, from its ports to named objects on the chart.

Transports, framers, codecs and drivers for its instruments (the core); the simulator (:mod:`auvlink.sim`);
the detection pipeline, live and on replay (:mod:`auvlink.pipeline`); evaluation (:mod:`auvlink.evaluation`);
the ``auvlink`` command (:mod:`auvlink.cli`). Layers: docs/ARCHITECTURE.md.

The Python API (:mod:`auvlink.api`, loaded on first use so that ``import auvlink`` stays light):

* ``auvlink.read(path, format)`` - the records of a raw capture (or of a mission log), streamed;
* ``auvlink.open_log(path)`` - a mission log: channels, metadata, loss report, decoded records;
* ``auvlink.replay(log)`` - detections as the pipeline makes them, then ``.result``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from auvlink.version import __version__

if TYPE_CHECKING:
    from auvlink.api import LogRecord, MissionLog, ReplayRun, open_log, read, replay

__all__ = ["LogRecord", "MissionLog", "ReplayRun", "__version__", "open_log", "read", "replay"]

_API = frozenset(__all__) - {"__version__"}


def __getattr__(name: str) -> Any:
    """PEP 562: the API names load :mod:`auvlink.api` (and the pipeline behind it) on first use."""
    if name in _API:
        from auvlink import api  # lazy on purpose: the facade reaches the application layer on demand

        value = getattr(api, name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'auvlink' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | _API)
