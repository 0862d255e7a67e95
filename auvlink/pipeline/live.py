"""The onboard loop: every port of a vehicle configuration -> log + streaming engine -> DIR, as it goes.

Threads: one :class:`~auvlink.pipeline.ports.PortReader` per device (reopened with backoff when its
port goes) and this one, the engine. Each raw frame goes first to the mission log (a listener on
the driver, like ``auvlink record``), then the decoded sample to a bounded queue: sonar frames to a
small one (``sonar_queue`` frames; when it is full the frame is dropped whole, counted and marked in
the log), navigation samples to a large one. Neither a driver nor the log ever waits for the
engine. The engine releases samples once every reader's watermark has passed them, so its results
depend on the samples only; the engine settings and time origin go into the log, and
``auvlink replay`` of that log gives the same detections (it skips the frames live dropped).

Events (port lost / reopened, frames dropped, the log failing) go to the log's ``events`` channel
(JSON, schema ``auvlink.Event``) and to the summary, folded into counts there
(:class:`~auvlink.pipeline.events.EventFolder`: the summary stays small whatever a device does; the log
gets every frame drop and, of a repeated event, the first ten and then the powers of two, with ``count``).
``stop`` (SIGINT / SIGTERM in the CLI) or the end of ``duration`` flushes everything: the engine finishes
the open objects, DIR gets its files, the log its last chunk and summary. A log that cannot be written
stops the run the same way, with the message in ``LiveRun.fatal``; what was written before stays
readable, and DIR still gets every file that can be written (``summary["unwritten"]`` lists the others).
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from auvlink.clock import now_ns
from auvlink.config import VehicleConfig, load_config
from auvlink.errors import AuvlinkError
from auvlink.oculus_driver import driver_for_device
from auvlink.pipeline.engine import Engine, EngineConfig
from auvlink.pipeline.engine_hooks import EngineHooks
from auvlink.pipeline.events import EventFolder
from auvlink.pipeline.fan_frames import FanRecorder
from auvlink.pipeline.log_meta import LIVE_META
from auvlink.pipeline.nav_inputs import SONAR_FORMATS
from auvlink.pipeline.object_labels import TORCH_THREADS, ObjectLabeller
from auvlink.pipeline.outputs import DetectionStream, check_ply_frame, write_outputs
from auvlink.pipeline.ports import EVENT_SCHEMA, EVENT_SCHEMA_NAME, EVENT_TOPIC, PortReader
from auvlink.pipeline.process import result_of
from auvlink.pipeline.results import Detection, MissionResult
from auvlink.pipeline.setup import MissionSetup
from auvlink.records import Sample
from logs_format.writer import MissionLogWriter


class LiveRun:
    """One live run (see the module docstring); :meth:`run` blocks until stopped and returns the result."""

    def __init__(self, config: VehicleConfig | str | Path, out_dir: Path, *, log_path: Path | None = None,
                 duration: float | None = None, stop: threading.Event | None = None, classify: bool = True,
                 model: Path | None = None, sonar_queue: int = 10, engine_config: EngineConfig | None = None,
                 compression: str = "zstd", on_detection: Callable[[Detection], None] | None = None,
                 ready: threading.Event | None = None,
                 backoff_max: float = 5.0, on_ready: Callable[[], None] | None = None,
                 ply_frame: str = "ned") -> None:
        self.config = config if isinstance(config, VehicleConfig) else load_config(config)
        self.out_dir = Path(out_dir)
        self.log_path = Path(log_path) if log_path is not None else self.out_dir / "mission.mcap"
        self.duration = duration
        self.stop = stop or threading.Event()
        self.ready = ready
        self.engine_config = engine_config or EngineConfig(frame_block=1)
        self.classify, self.model, self.compression = classify, model, compression
        self.backoff_max = backoff_max
        self.on_ready = on_ready
        self.ply_frame = check_ply_frame(ply_frame)
        self.sonar_q: queue.Queue[Sample] = queue.Queue(maxsize=sonar_queue)
        self.nav_q: queue.Queue[Sample] = queue.Queue(maxsize=100_000)
        self.drops: dict[str, int] = {}
        self._delivered: dict[str, int] = {}  # samples handed over per device (each device: one reader thread)
        self.events = EventFolder()  # port events, folded into counts (summary.json's "events")
        self.fatal = ""
        self.summary: dict[str, Any] = {}  # summary.json's content, once run() returns
        self._log: Any = None
        self._user_on_detection = on_detection
        self._lock = threading.Lock()

    # ------------------------------------------------------------------ callbacks (reader threads)
    def _event(self, ev: dict[str, Any]) -> None:
        count = self.events.add(ev)
        log = self._log
        if log is not None and not self.fatal and EventFolder.logs(ev, count):
            try:
                log.add_json(EVENT_TOPIC, EVENT_SCHEMA_NAME, EVENT_SCHEMA, int(ev["t_ns"]),
                             {**ev, "count": count} if count > 1 else ev)
            except AuvlinkError as exc:
                self._fail(exc)

    def _fail(self, exc: BaseException) -> None:
        reason = getattr(exc.__cause__, "strerror", None) or str(exc)  # e.g. "No space left on device"
        with self._lock:
            if not self.fatal:
                self.fatal = f"writing the mission log {self.log_path} failed: {reason}"
        self.stop.set()

    def _log_tap(self, device: str, fmt: str, t_host_ns: int, raw: bytes, t_sensor_ns: int | None = None) -> None:
        if self.fatal:
            return
        try:
            self._log(device, fmt, t_host_ns, raw, t_sensor_ns=t_sensor_ns)
        except AuvlinkError as exc:
            self._fail(exc)

    def _deliver(self, sample: Sample) -> None:
        index = self._delivered.get(sample.device, 0)  # the sample's ordinal in its device's stream
        self._delivered[sample.device] = index + 1
        q = self.sonar_q if sample.format in SONAR_FORMATS else self.nav_q
        try:
            q.put_nowait(sample)
        except queue.Full:
            self.drops[sample.device] = self.drops.get(sample.device, 0) + 1
            # frames read together share a receive time; the ordinal says which one (replay counts the same)
            self._event({"t_ns": now_ns(), "device": sample.device, "kind": "frame_dropped",
                         "frame_t_ns": sample.t_host_ns, "sample_index": index})

    # ------------------------------------------------------------------ the run
    def run(self) -> MissionResult:
        t_start = time.perf_counter()
        try:
            self.out_dir.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise AuvlinkError(f"cannot create the output folder {self.out_dir}: {exc.strerror or exc}") from exc
        setup = MissionSetup.from_config(self.config)
        stream = DetectionStream(self.out_dir, self.ply_frame)

        def on_detection(det: Detection) -> None:
            stream(det)
            if self._user_on_detection is not None:
                self._user_on_detection(det)

        t0_ns = now_ns()
        fans = FanRecorder()
        engine = Engine(setup, self.engine_config, t0_ns=t0_ns, labeller=ObjectLabeller(self.classify, self.model,
                                                                          torch_threads=TORCH_THREADS["live"]),
                        hooks=EngineHooks(on_detection=on_detection, on_frames=fans, clock=now_ns))
        log = MissionLogWriter(self.log_path, compression=self.compression)  # LogError: one clear line
        self._log = log
        try:
            engine.warm_up()
        except BaseException:
            log.close()
            raise
        readers: list[PortReader] = []
        stop_readers = threading.Event()
        try:
            log.add_vehicle_config(self.config)
            log.add_metadata(LIVE_META, {"t0_ns": t0_ns, "engine": self.engine_config.to_dict()})
            for dev in self.config.devices:
                drv = driver_for_device(dev.name, dev.format, dev.url, dev.options)
                drv.add_raw_listener(self._log_tap, sensor_time=True)
                readers.append(PortReader(drv, self._deliver, stop_readers, on_event=self._event,
                                          backoff_max=self.backoff_max))
            for r in readers:
                r.start()
            if self.ready is not None:
                self.ready.set()
            if self.on_ready is not None:
                self.on_ready()
            self._loop(engine, readers)
        finally:
            stop_readers.set()
            for r in readers:
                r.join(5.0)
            self._drain(engine)
            engine.finish()
            try:
                log.close()
            except AuvlinkError as exc:
                self._fail(exc)
        devices = {r.driver.name: r.describe() for r in readers}
        timings = {"navigation_s": engine.times.total("navigation"),
                   "reconstruction_s": engine.times.total("reconstruction"),
                   "clustering_s": engine.times.total("clustering"),
                   "classification_s": engine.times.total("classification"),
                   "total_s": time.perf_counter() - t_start}
        result = result_of(engine, self.log_path, timings, devices, self.fatal, mode="live", drops=self.drops,
                           events=self.events.to_list(), fan_frames=fans.frames)
        self.summary = write_outputs(result, self.out_dir, keep_going=True, ply_frame=self.ply_frame)
        unwritten = self.summary.get("unwritten")
        if unwritten or stream.error is not None:
            what = ", ".join(unwritten) if unwritten else f"detections as they came ({stream.error})"
            with self._lock:
                self.fatal = "; ".join(filter(None, [self.fatal, f"not written in {self.out_dir}: {what}"]))
        return result

    def _drain(self, engine: Engine) -> int:
        n = 0
        for q in (self.nav_q, self.sonar_q):
            while True:
                try:
                    engine.feed(q.get_nowait())
                except queue.Empty:
                    break
                n += 1
        return n

    def _loop(self, engine: Engine, readers: list[PortReader]) -> None:
        end = None if self.duration is None else time.monotonic() + self.duration
        while not self.stop.is_set() and (end is None or time.monotonic() < end):
            now = now_ns()  # read before the readers' state: see PortReader.holds_from
            watermark = min(r.holds_from(now) for r in readers) if readers else now
            n = self._drain(engine)
            engine.advance(watermark)
            if n == 0:
                self.stop.wait(0.005)
