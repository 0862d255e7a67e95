"""The pipeline on a log: :func:`replay` -> :class:`ReplayRun` (detections as they are made, then the result)."""

from __future__ import annotations

import math
import queue
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any, cast

from auvlink.api.log import MissionLog
from auvlink.errors import AuvlinkError

if TYPE_CHECKING:
    from auvlink.pipeline.results import Detection, MissionResult


#: most detections a replay holds for a slow consumer (a survey makes a few hundred)
MAX_BUFFER = 100_000


class _Stopped(Exception):
    """Raised inside the pipeline thread when the consumer stopped iterating."""


def _put(q: queue.Queue[tuple[str, Any]], stop: threading.Event, item: tuple[str, Any]) -> None:
    """Hand ``item`` to the consumer, waiting while the queue is full; :class:`_Stopped` once stopped."""
    while True:
        if stop.is_set():
            raise _Stopped
        try:
            q.put(item, timeout=0.1)
            return
        except queue.Full:
            continue


def _work(run: Callable[[Callable[[Detection], None]], MissionResult], q: queue.Queue[tuple[str, Any]],
          stop: threading.Event) -> None:
    """The pipeline thread: each detection, then the result (or the exception) onto ``q``."""
    try:
        result = run(lambda det: _put(q, stop, ("det", det)))
    except _Stopped:
        return
    except BaseException as exc:  # handed to the consumer, raised there
        try:
            _put(q, stop, ("err", exc))
        except _Stopped:
            pass
        return
    try:
        _put(q, stop, ("end", result))
    except _Stopped:
        pass


class ReplayRun(Iterator["Detection"]):
    """A replay in progress: iterate for the :class:`~auvlink.pipeline.results.Detection` objects as the
    engine makes them (the engine runs in a thread and waits when the consumer is slower: at most
    ``buffer`` detections are held); :attr:`result` is the whole :class:`MissionResult` after the last.

    To stop early call :meth:`close` (or use the run as a context manager): the engine stops at its
    next detection (it has no other point to stop at) and its thread ends; a run no longer referenced
    stops the same way.
    """

    def __init__(self, run: Callable[[Callable[[Detection], None]], MissionResult], buffer: int = 16) -> None:
        self._q: queue.Queue[tuple[str, Any]] = queue.Queue(maxsize=buffer)
        self._stop = threading.Event()
        self._result: MissionResult | None = None
        # the thread holds the queue and the event, not this object: a run nobody holds is collected
        # (``__del__`` then stops the engine)
        self._thread = threading.Thread(target=_work, args=(run, self._q, self._stop), name="auvlink-replay",
                                        daemon=True)
        self._done = False
        self._thread.start()

    def __next__(self) -> Detection:
        if self._done:
            raise StopIteration
        kind, value = self._q.get()
        if kind == "det":
            return cast("Detection", value)
        self._done = True
        self._thread.join()
        if kind == "err":
            raise value
        self._result = value
        raise StopIteration

    @property
    def result(self) -> MissionResult:
        """The whole run (detections, track, timings, device statistics); iterates to the end first."""
        for _ in self:
            pass
        if self._result is None:
            raise AuvlinkError("the replay was stopped before its end: no result")
        return self._result

    def close(self) -> None:
        """Stop the engine (when still running) and wait for its thread."""
        if not self._done:
            self._done = True
            self._stop.set()
            self._thread.join()

    def __enter__(self) -> ReplayRun:
        return self

    def __exit__(self, et: type[BaseException] | None, ev: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def __del__(self) -> None:
        self._stop.set()


def replay(log: str | Path | MissionLog, *, classify: bool = True, model: str | Path | None = None,
           speed: float | None = None, progress: bool = False, buffer: int = 16) -> ReplayRun:
    """Replay a mission log through the streaming pipeline (the engine of ``auvlink replay``).

    ``log`` is a path or a :class:`MissionLog`; ``classify=False`` stops after clustering (class
    ``unknown``); ``model`` a classifier checkpoint (default: the shipped one); ``speed`` paces the
    replay at that multiple of real time (None: as fast as possible). Returns a :class:`ReplayRun`:
    iterate it for the detections, then read ``.result``. Write the usual output folder with
    :func:`auvlink.pipeline.outputs.write_outputs` and :func:`auvlink.pipeline.report.write_report`.
    """
    from auvlink.pipeline.process import run_log  # lazy: SciPy, the engine and (when classifying) PyTorch

    path = log.path if isinstance(log, MissionLog) else Path(log)
    if not path.is_file():
        raise AuvlinkError(f"{path}: no such log")
    if speed is not None and not (math.isfinite(speed) and speed > 0):
        raise AuvlinkError(f"speed must be a finite number > 0, got {speed} (None: as fast as possible)")
    if not 1 <= buffer <= MAX_BUFFER:  # queue.Queue takes 0 or less as "unbounded"
        raise AuvlinkError(f"buffer must be in [1, {MAX_BUFFER}] detections, got {buffer}")
    ckpt = Path(model) if model is not None else None
    return ReplayRun(lambda cb: run_log(path, speed=speed, model=ckpt, classify=classify, progress=progress,
                                        on_detection=cb), buffer=buffer)
