"""Run the pipeline on a mission log: replay -> the streaming engine -> detections.

Replay goes through :class:`logs_format.Replay`, i.e. the same decoders (framer + codec) as live
operation, for the channels whose wire format a stage consumes
(:data:`auvlink.pipeline.nav_inputs.CONSUMED_FORMATS`; the others are counted, not decoded), and
the samples through :class:`auvlink.pipeline.engine.Engine`, the engine of ``auvlink live``. Each
stage is timed; the result (:mod:`auvlink.pipeline.results`) carries everything the outputs and the
report need. The non-causal batch reference for tests is :func:`auvlink.evaluation.noncausal_reference.run_log_batch`.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from auvlink.config import VehicleConfig
from auvlink.pipeline.engine import Engine, EngineConfig
from auvlink.pipeline.engine_hooks import EngineHooks
from auvlink.pipeline.fan_frames import FanRecorder
from auvlink.pipeline.log_meta import live_settings
from auvlink.pipeline.mission_deadline import check as check_deadline
from auvlink.pipeline.nav_inputs import CONSUMED_FORMATS
from auvlink.pipeline.object_labels import TORCH_THREADS, ObjectLabeller
from auvlink.pipeline.results import Detection, FanFrame, MissionResult
from auvlink.pipeline.setup import MissionSetup
from auvlink.progress import progress_bar
from logs_format import MissionLogReader, Replay
from logs_format.bounded_json import loads_bounded
from recon.reconstructor import ReconConfig

FRAME_BLOCK = 64  # frames per reconstruction call when replaying a log not recorded live


def read_setup(reader: MissionLogReader, config: VehicleConfig | None = None
               ) -> tuple[MissionSetup, EngineConfig | None, int | None, list[str]]:
    """From a log's metadata (:mod:`auvlink.pipeline.log_meta`): the mission set-up (``config`` replacing the
    stored vehicle configuration), the engine settings and time origin a live run stored (None, None
    otherwise) and one warning line per value refused or replaced by its default."""
    meta = reader.metadata(decode_json=True)
    setup = MissionSetup.from_metadata(meta, config)
    engine, t0_ns, warnings = live_settings(meta, reader.start_ns, reader.end_ns)
    if setup.truth_skipped:
        warnings.insert(0, f"{setup.truth_skipped} ground-truth entries left out as unusable "
                           f"(the first: {setup.truth_problem})")
    return setup, engine, t0_ns, [*reader.metadata_problems, *filter(None, [setup.warning]), *warnings]


def print_warnings(log: Path, warnings: list[str]) -> None:
    """Each warning as one line on stderr, naming the log."""
    for line in warnings:
        print(f"auvlink: warning: {log}: {line}", file=sys.stderr)


def run_log(log: Path, *, speed: float | None = None, model: Path | None = None, classify: bool = True,
            progress: bool = True, recon_config: ReconConfig | None = None,
            engine_config: EngineConfig | None = None,
            on_detection: Callable[[Detection], None] | None = None,
            config: VehicleConfig | None = None, clutter_threshold: float | None = None,
            torch_threads: int | None = TORCH_THREADS["replay"]) -> MissionResult:
    """The streaming engine on a log (``auvlink replay``): the same engine as ``auvlink live``.

    A log written by ``auvlink live`` carries the live engine settings and time origin; they are
    used unless ``engine_config`` is given, so the replay gives the live detections. ``config``
    (``--config``) replaces the vehicle configuration the log stores; a stored configuration that
    fails validation is replaced by the defaults with one warning line on stderr. ``clutter_threshold``
    replaces the checkpoint's (``math.inf``: no cluster is called clutter; the result's ``clutter_scores`` keep
    every classification's probability of clutter, :mod:`auvlink.evaluation.clutter_sweep`). ``torch_threads``:
    PyTorch's threads for the classifier (default: replay's, :data:`~auvlink.pipeline.object_labels.TORCH_THREADS`;
    a batch worker passes its own; None: left as they are).
    """
    t_start = time.perf_counter()
    with MissionLogReader(log) as reader:
        setup, live_cfg, t0_ns, warnings = read_setup(reader, config)
        duration = reader.duration_s
        log_start = reader.start_ns
        dropped = dropped_live(reader)
    print_warnings(log, warnings)
    cfg = engine_config or live_cfg or EngineConfig(frame_block=FRAME_BLOCK)
    fans = FanRecorder()
    engine = Engine(setup, cfg, t0_ns=t0_ns, recon_config=recon_config,
                    labeller=ObjectLabeller(classify, model, clutter_threshold, torch_threads),
                    hooks=EngineHooks(on_detection=on_detection, on_frames=fans))
    # no warm-up: PyTorch loads at the first classification (clustering needs no Open3D), off the path to
    # the first frame (start_up_s: from this call to the first frames processed)
    warm_s: float | None = None
    replay = Replay(log, speed=speed, formats=CONSUMED_FORMATS)
    bar = progress_bar(total=round(duration or 0.0, 1), enabled=progress, unit="s", desc="replay",
                       leave=False, bar_format="{l_bar}{bar}| {n:.0f}/{total:.0f} s mission [{elapsed}]")
    last_adv = None
    shown = 0.0
    decode_s = 0.0
    skipped: dict[str, int] = {}
    index: dict[str, int] = {}  # per device: the sample's ordinal, as live counted it
    t_read = time.perf_counter()
    with replay:
        for sample in replay.samples():
            t_ns = sample.t_host_ns
            if dropped:
                k = index.get(sample.device, 0)
                index[sample.device] = k + 1
                if (sample.device, k) in dropped or (sample.device, -1, t_ns) in dropped:  # live never had it
                    skipped[sample.device] = skipped.get(sample.device, 0) + 1
                    continue
            engine.feed(sample)
            if last_adv is None:
                last_adv = t_ns
            elif t_ns - last_adv >= ADVANCE_NS:
                decode_s += time.perf_counter() - t_read
                check_deadline()  # a mission's time limit (auvlink batch --mission-timeout) stops it here
                if engine.advance(t_ns) and warm_s is None:
                    warm_s = time.perf_counter() - t_start
                last_adv = t_ns
                t_read = time.perf_counter()
                t = min((t_ns - (log_start or t_ns)) * 1e-9, bar.total or 0.0)
                if t - shown >= 1.0:
                    bar.update(t - shown)
                    shown = t
        decode_s += time.perf_counter() - t_read
        check_deadline()
        engine.finish()
        stats = replay.stats()
        loss = replay.loss.to_json()  # what the log lost (logs_format.loss.LossReport), as JSON
    bar.close()
    start_up_s = warm_s if warm_s is not None else time.perf_counter() - t_start
    timings = {"start_up_s": start_up_s, "replay_decode_s": decode_s, "navigation_s": engine.times.total("navigation"),
               "reconstruction_s": engine.times.total("reconstruction"),
               "clustering_s": engine.times.total("clustering"),
               "classification_s": engine.times.total("classification"),
               "total_s": time.perf_counter() - t_start}
    return result_of(engine, log, timings, stats, loss, mode="replay", drops=skipped, fan_frames=fans.frames)


def dropped_live(reader: MissionLogReader) -> set[tuple[str, int] | tuple[str, int, int]]:
    """The frames a live run dropped (its ``events`` channel): ``(device, sample ordinal in that device's
    stream)``; ``(device, -1, receive time ns)`` for events without the ordinal (logs of earlier versions:
    frames read together share that time, so these may skip a frame live kept)."""
    if "events" not in reader.channels:
        return set()
    out: set[tuple[str, int] | tuple[str, int, int]] = set()
    for msg in reader.messages(channels=["events"]):
        try:
            ev = loads_bounded(msg.data)
        except ValueError:
            continue
        if not isinstance(ev, dict) or ev.get("kind") != "frame_dropped":
            continue
        index, t_ns = ev.get("sample_index"), ev.get("frame_t_ns")
        if isinstance(index, int):
            out.add((str(ev.get("device")), index))
        elif isinstance(t_ns, int):
            out.add((str(ev.get("device")), -1, t_ns))
    return out


ADVANCE_NS = 4_000_000_000  # replay hands samples to the engine in 4 s blocks (results do not depend on it)


def result_of(engine: Engine, log: Path | None, timings: dict[str, float], stats: dict[str, Any],
              loss: dict[str, Any] | str,
              mode: str, drops: dict[str, int] | None = None, events: list[dict[str, Any]] | None = None,
              fan_frames: list[FanFrame] | None = None) -> MissionResult:
    return MissionResult(log=log, setup=engine.setup, detections=engine.detections, track=engine.track(),
                         t0=(engine.t0_ns or 0) * 1e-9, strip=engine.strip, geometry=engine.geometry,
                         timings=timings, latency=engine.times.summary(), replay_stats=stats,
                         recon_stats=engine.recon_stats(), loss=loss, highlight_points=engine.highlight_points(),
                         drops=dict(drops or {}), events=list(events or []), mode=mode,
                         engine=engine.config.to_dict(), georef=engine.georef.summary(),
                         track_info=engine.track_table(), t0_ns=engine.t0_ns or 0, poses=engine.poses(),
                         fan_frames=list(fan_frames or []), clutter_scores=list(engine.clutter_scores))
