"""The Python API: read captures, open mission logs, replay a log through the pipeline.

Reached from the root package (``auvlink.read``, ``auvlink.open_log``, ``auvlink.replay``; loaded on
first use, PEP 562, so ``import auvlink`` stays light):

* :func:`read` - the records of a raw capture of one wire format (or of a mission log), streamed.
* :func:`open_log` - a mission log: channels, metadata, the loss report, decoded records.
* :func:`replay` - a log through the streaming pipeline: detections as they are made, then the result.

Times are ns (log/receive time, UNIX epoch) unless a name says ``_s``; positions are world NED, m.
"""

from __future__ import annotations

from auvlink.api.capture import Records, read
from auvlink.api.log import LogRecord, MissionLog, open_log
from auvlink.api.run import ReplayRun, replay

__all__ = ["LogRecord", "MissionLog", "Records", "ReplayRun", "open_log", "read", "replay"]
