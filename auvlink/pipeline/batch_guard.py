"""What ``auvlink batch`` checks before trusting its inputs and its own folder.

* :func:`check_scheduler_address`: a ``--scheduler`` address is ``PROTOCOL://HOST:PORT`` with a protocol
  :mod:`distributed` knows (``inproc://`` needs no port); anything else, the empty string included,
  is one line before any work (an empty address never falls back to a local cluster).
* :func:`check_mcap_magic`: a log's first 8 bytes are the MCAP magic before it is hashed, so a large
  file that is not a log is refused after reading 8 bytes, not after reading it whole.
* :func:`time_limit`: a mission's time limit (``--mission-timeout``, :data:`DEFAULT_MISSION_TIMEOUT_S`).
  When it passes, the mission stops itself with :class:`MissionTimeout` at its next check
  (:mod:`auvlink.pipeline.mission_deadline`: the replay loop checks between frame blocks, where nothing is
  half done). Only a mission that reaches no check for :data:`FALLBACK_GRACE_S` more gets the exception from
  outside, in its thread at its next bytecode (a native call under way finishes first), never while a module
  is being imported (an import cut in two would leave the worker a half-initialised module) nor while that
  thread is inside ``Thread.start``: CPython 3.11 gives a thread being started its parent's id until it runs,
  so the exception could land on the new thread, which dies before telling its parent it started, and the
  parent waits for it forever. That check and the exception cannot be made one step from Python, so the
  outside exception is a last resort (a loop starting threads without pause can still meet the race; the
  replay loop never meets it, as it stops itself first). Either way the mission's folder is written
  atomically, so it keeps what it had, and the worker goes on with the next mission.
* :func:`output_digests` / :func:`outputs_intact`: a mission record keeps the SHA-256 of every file the
  mission wrote, so a folder whose outputs were edited or deleted is processed again, not skipped;
  :func:`seal` / :func:`sealed`: the record carries the SHA-256 of its own content, so an edited
  record is too.
* :func:`only_mission_files`: a mission folder with no readable record is processed again when it
  holds nothing but what a mission writes (nothing of a user's is replaced without ``--force``).
"""

from __future__ import annotations

import ctypes
import hashlib
import json
import os
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from auvlink.errors import AuvlinkError
from auvlink.file_digest import sha256_file
from auvlink.pipeline.mission_deadline import MissionTimeout as MissionTimeout  # raised here, caught by callers
from auvlink.pipeline.mission_deadline import deadline
from auvlink.pipeline.run_guard import REPLAY_OUTPUTS
from logs_format.records import MAGIC

#: default ``--mission-timeout`` (s): a 30-minute mission replays in about 30 s on one worker (RESULTS.md,
#: 65x real time), so 2 h leaves room for a mission a hundred times longer, or a much slower worker
DEFAULT_MISSION_TIMEOUT_S = 7200.0
RECORD_FILE = "batch.json"
SEAL_KEY = "record_sha256"
PORTLESS_PROTOCOLS = ("inproc",)  # distributed's in-process transport: an address without a port
IMPORT_POLL_S = 0.05  # s: how often a due time limit looks again whether an import or a thread start has ended
#: s after the limit before the exception is sent from outside (a mission that reached no check, stuck before or
#: after its replay loop): the loop checks every 0.1-1 s of mission time, under a second of work at 50x real time,
#: so a mission still running 30 s after its limit is not in it; rare by design, as the last resort is not
#: race-free (module doc)
FALLBACK_GRACE_S = 30.0
_THREAD_START = threading.Thread.start.__code__


def check_scheduler_address(address: str) -> str:
    """``address`` when it is a scheduler address :mod:`distributed` can dial; else one :class:`AuvlinkError`."""
    from distributed.comm.addressing import parse_address, parse_host_port
    from distributed.comm.registry import backends

    fix = "give a scheduler address such as tcp://host:8786 (or leave --scheduler out for a local cluster)"
    try:
        protocol, location = parse_address(address, strict=True)
    except ValueError as exc:
        raise AuvlinkError(f"--scheduler {address!r}: no protocol://; {fix}") from exc
    if protocol not in backends:
        raise AuvlinkError(f"--scheduler {address!r}: unknown protocol {protocol!r} (known: "
                           f"{', '.join(sorted(backends))}); {fix}")
    if protocol in PORTLESS_PROTOCOLS:
        return address
    try:
        host, port = parse_host_port(location)
    except ValueError as exc:
        raise AuvlinkError(f"--scheduler {address!r}: {exc}; {fix}") from exc
    if not host.strip() or any(c.isspace() for c in host) or not 0 < int(port) < 65536:
        raise AuvlinkError(f"--scheduler {address!r}: host {host!r}, port {port}: not an address; {fix}")
    return address


def check_mcap_magic(path: str | os.PathLike[str]) -> None:
    """Raise :class:`AuvlinkError` unless the file starts with the MCAP magic (reads 8 bytes)."""
    with open(path, "rb") as f:
        head = f.read(len(MAGIC))
    if head != MAGIC:
        raise AuvlinkError(f"{path}: not an MCAP mission log (it starts with {head!r}, not {MAGIC!r})")


@contextmanager
def time_limit(seconds: float | None) -> Iterator[None]:
    """Raise :class:`MissionTimeout` in this thread once ``seconds`` have passed in the block (module doc)."""
    if seconds is None:
        yield
        return
    target = threading.get_ident()
    state = {"done": False, "fired": False}
    guard = threading.Lock()
    over = threading.Event()

    def fire() -> None:
        wait = seconds + FALLBACK_GRACE_S
        while not over.wait(wait):
            with guard:
                if state["done"]:
                    return
                if not _importing() and not _starting_thread(target):
                    ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(target),
                                                               ctypes.py_object(MissionTimeout))
                    if not _starting_thread(target):
                        state["fired"] = True
                        return
                    # it began a thread start meanwhile: the exception may sit on the new thread (module
                    # doc); take it back from the first thread with that id, and try again
                    ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(target), None)
            wait = IMPORT_POLL_S

    timer = threading.Thread(target=fire, name="mission-time-limit", daemon=True)
    timer.start()
    try:
        with deadline(seconds):
            yield
    finally:
        with guard:
            state["done"] = True
            fired = state["fired"]
        over.set()
        timer.join()
        if fired:  # still pending when the block ended on its own: clear it, and say the limit passed
            ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(target), None)
    if fired:
        raise MissionTimeout


def _starting_thread(ident: int) -> bool:
    """Whether the thread ``ident`` is inside :meth:`threading.Thread.start` now (its frames, module doc)."""
    frame = sys._current_frames().get(ident)
    while frame is not None:
        if frame.f_code is _THREAD_START:
            return True
        frame = frame.f_back
    return False


def _importing() -> bool:
    """Whether a module is being imported now (importlib marks its spec ``_initializing`` until it is)."""
    return any(getattr(getattr(m, "__spec__", None), "_initializing", False) for m in list(sys.modules.values()))


def output_digests(folder: Path) -> dict[str, str]:
    """SHA-256 of every file under ``folder`` but its record, by path relative to it (``/``-separated)."""
    files = sorted(p for p in folder.rglob("*") if p.is_file() and p.name != RECORD_FILE)
    return {p.relative_to(folder).as_posix(): sha256_file(p) for p in files}


def outputs_intact(folder: Path, record: dict[str, Any]) -> bool:
    """Whether every file the record lists is in ``folder`` with the same SHA-256 (a record without the
    list cannot say: False)."""
    listed = record.get("outputs")
    if not isinstance(listed, dict) or not listed:
        return False
    try:
        return all(isinstance(d, str) and sha256_file(folder / str(rel)) == d for rel, d in listed.items())
    except OSError:
        return False


def _record_digest(record: dict[str, Any]) -> str:
    body = {k: v for k, v in record.items() if k != SEAL_KEY}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


def seal(record: dict[str, Any]) -> dict[str, Any]:
    """``record`` (JSON-ready) with the SHA-256 of its canonical JSON under :data:`SEAL_KEY`."""
    return {**record, SEAL_KEY: _record_digest(record)}


def edited(record: dict[str, Any]) -> bool:
    """Whether ``record`` was sealed (:func:`seal`) and changed since (a record without the seal cannot say)."""
    return SEAL_KEY in record and not sealed(record)


def sealed(record: dict[str, Any]) -> bool:
    """Whether ``record`` is as :func:`seal` left it (not edited since)."""
    try:
        return record.get(SEAL_KEY) == _record_digest(record)
    except (TypeError, ValueError):
        return False


def only_mission_files(folder: Path) -> bool:
    """Whether ``folder`` holds nothing but what a batch mission writes (the replay's files, its record,
    hidden temporary entries of an interrupted write)."""
    try:
        names = os.listdir(folder)
    except OSError:
        return False
    return all(n in REPLAY_OUTPUTS or n == RECORD_FILE or n.startswith(".") for n in names)
