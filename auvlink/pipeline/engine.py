"""The streaming engine: samples in time order -> causal navigation -> recon -> clusters -> classes.

One engine serves ``auvlink live`` (fed from the drivers) and ``auvlink replay`` / ``demo`` (fed from
the log). :meth:`Engine.feed` buffers decoded samples; :meth:`Engine.advance` releases those older
than a watermark (live: every driver has handed over everything it received before it; replay: the
time of the sample being read), in ``(receive time, arrival)`` order (a sonar frame's time is its ping's on the
host clock, :mod:`auvlink.pipeline.sensor_clock`):

1. navigation samples go to :class:`recon.nav_stream.CausalNavigator` (a pose at t uses samples up
   to t only, and is the same number however the samples were grouped);
2. sonar frames, pooled to recon's sampling (:mod:`recon.image_pooling`), go to the Reconstructor in groups of
   ``frame_block`` (it pulls the DVL seabed points up to the group's last frame from the navigator): the result
   depends on the samples and settings only, never on when they arrived; frames before the navigation or more
   than ``max_extrapolation_s`` past it are skipped and counted;
3. every ``poll_s`` of mission time the streaming clusterer finalizes the objects the vehicle is past; each is
   classified at once and handed to ``on_detection``, unless the classifier calls it ``clutter`` (seabed texture
   left by the seabed removal): then it is counted (``rejected_clutter``), not reported. A later pass fused into
   a rejected one (same id) is classified afresh and reported if it is an object now; an object once reported
   stays one (its updates get the best object class, at once when its evidence changed enough, else on its final
   cloud at :meth:`Engine.finish`: :mod:`~auvlink.pipeline.object_labels`);
4. GNSS fixes and depth go to :class:`auvlink.pipeline.georef.Georef`: dead reckoning runs in its own
   frame D (origin: the first navigation sample); a detection is handed on in W with the start anchor
   (the pre-dive fixes), and :meth:`Engine.finish` moves every detection and the track by the drift
   correction (the closure error after surfacing, linear in time over the submerged track).

Replaying a log recorded by ``auvlink live`` with the live settings (stored in the log) therefore
gives the live detections, apart from the frames the live run dropped (counted there).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from auvlink.geodesy import Datum
from auvlink.pipeline.detection_store import DetectionStore
from auvlink.pipeline.engine_config import EngineConfig, default_recon_config
from auvlink.pipeline.engine_hooks import EngineHooks
from auvlink.pipeline.event_queue import EventQueue
from auvlink.pipeline.frame_gate import survey_frames
from auvlink.pipeline.georef import Georef
from auvlink.pipeline.latency import StageTimes
from auvlink.pipeline.nav_inputs import Event, SonarPayload
from auvlink.pipeline.object_labels import ObjectLabeller, make_detection
from auvlink.pipeline.results import Detection, Poses, StripFrame
from auvlink.pipeline.setup import MissionSetup, nav_config, sonar_geometry
from auvlink.pipeline.strip_picker import StripPicker
from auvlink.records import Sample
from classify.labels import CLUTTER
from recon.cluster import DetectedObject, dbscan_labels
from recon.image_pooling import ImagePooling
from recon.nav import pressure_to_depth
from recon.nav_stream import CausalNavigator
from recon.reconstructor import ReconConfig, Reconstructor
from recon.sonar_geometry import SonarGeometry


class Engine:
    """See the module docstring. Its parts: the input (:class:`~auvlink.pipeline.event_queue.EventQueue`), the
    causal navigator and the georeference, recon (:class:`recon.reconstructor.Reconstructor`, made at the first
    usable frame), the classifier (:class:`~auvlink.pipeline.object_labels.ObjectLabeller`; default: the shipped
    model), the detections (:class:`~auvlink.pipeline.detection_store.DetectionStore`) and the report's frames
    (:class:`~auvlink.pipeline.strip_picker.StripPicker`)."""

    def __init__(self, setup: MissionSetup, config: EngineConfig | None = None, *, t0_ns: int | None = None,
                 recon_config: ReconConfig | None = None, labeller: ObjectLabeller | None = None,
                 hooks: EngineHooks | None = None, strip: StripPicker | None = None) -> None:
        self.setup = setup
        self.config = config or EngineConfig()
        self.recon_config = recon_config or default_recon_config()
        self.inbox = EventQueue(t0_ns)
        self.nav = CausalNavigator(nav_config(setup), self.config.max_extrapolation_s)
        gm = setup.gnss_mounting
        self.georef = Georef(Datum.of_site(setup.site), gm.xyz if gm is not None else (0.0, 0.0, 0.0), gm is not None)
        self.store = DetectionStore(self.georef)
        self.labeller = labeller or ObjectLabeller(True, None)
        self.hooks = hooks or EngineHooks()
        self.strip_picker = strip or StripPicker()
        self.times = StageTimes()
        self.counts = {"frames": 0, "frames_processed": 0, "frames_without_navigation": 0, "polls": 0,
                       "frames_timed_by_ping": 0}
        self.rec: Reconstructor | None = None
        self.geometry: SonarGeometry | None = None  # recon's: the frames' pooled to its sampling
        self.pooling, self._frame_shape = ImagePooling(), (0, 0)  # (range lines, beams) of the frames
        self._frames: list[tuple[int, SonarPayload]] = []
        self._poll_k = -1
        self._t_last = -math.inf
        self._finished = False

    @property
    def t0_ns(self) -> int | None:
        """ns since the epoch of mission time 0 (the first event's receive time unless the run gave it)."""
        return self.inbox.t0_ns

    @t0_ns.setter
    def t0_ns(self, value: int | None) -> None:
        self.inbox.t0_ns = value

    @property
    def detections(self) -> list[Detection]:
        return self.store.detections

    @property
    def strip(self) -> list[StripFrame]:
        return self.strip_picker.frames

    # ------------------------------------------------------------------ input
    def load_classifier(self) -> None:
        """Load the classifier now (live does it before opening the ports)."""
        self.labeller.load()

    @property
    def clutter_scores(self) -> list[tuple[int, float]]:
        """(object id, probability of clutter) of every classification, in order (:class:`ObjectLabeller`)."""
        return self.labeller.scores

    def warm_up(self) -> None:
        """Load the classifier and the clustering library now, before the first frame: live does it
        before opening the ports (no first-object stall), and replay too, so both compute in the same
        process state (loading PyTorch changes the threading of the numerical libraries, and with it
        the last bits of some sums)."""
        self.load_classifier()
        dbscan_labels(np.random.default_rng(0).normal(size=(64, 3)), 0.5, 8)

    def feed(self, sample: Sample) -> None:
        """Buffer a decoded sample (:meth:`EventQueue.put`)."""
        self.inbox.put(sample)

    def advance(self, watermark_ns: int | None = None) -> int:
        """Process every buffered event older than ``watermark_ns`` (all with None); returns frames done."""
        if not self.inbox:
            return self._run_frames(final=watermark_ns is None)
        out = self.inbox.release(watermark_ns)
        self._navigate(out)
        self._frames.extend((e.t_ns, e.payload) for e in out if e.kind == "sonar")
        return self._run_frames(final=watermark_ns is None)

    def _navigate(self, events: list[Event]) -> None:
        t0 = time.perf_counter()
        d, g, p = self.inbox.adaptor.nav_inputs(events, self.t0_ns or 0)
        gnss = [e for e in events if e.kind == "gnss"]
        if d is None and g is None and p is None and not gnss:
            return
        if d is not None or g is not None or p is not None:
            self.nav.add(d, g, p)
        if p is not None:
            c = self.nav.config
            self.georef.on_depth(np.asarray(p.t), pressure_to_depth(p.pressure_pa, c.seawater_density, c.gravity,
                                                                    c.atmospheric_pa))
        for e in gnss:
            self.georef.on_fix(self.inbox.seconds(e.t_ns), e.payload, self.nav)
        self.times.add("navigation", time.perf_counter() - t0)

    # ------------------------------------------------------------------ frames
    def _run_frames(self, final: bool) -> int:
        b = max(1, int(self.config.frame_block))
        done = 0
        while len(self._frames) >= b or (final and self._frames):
            group, self._frames = self._frames[:b], self._frames[b:]
            done += self._group(group)
        return done

    def _group(self, group: list[tuple[int, SonarPayload]]) -> int:
        """One group of frames: gated (:func:`~auvlink.pipeline.frame_gate.survey_frames`), reconstructed, then
        a poll when ``poll_s`` of mission time has passed; returns the frames reconstructed."""
        t_start = time.perf_counter()
        self.counts["frames"] += len(group)
        self.counts["frames_timed_by_ping"] += sum(fr.received_ns > t for t, fr in group)
        times = np.array([self.inbox.seconds(t) for t, _ in group])
        ok = survey_frames(self.nav, times, self.config, self.counts)
        for (_, fr), t in zip(group, times, strict=True):
            self.strip_picker.remember(float(t), fr.image)
        if not ok.any():
            return 0
        sel = np.flatnonzero(ok)
        rec = self._reconstructor(group[int(sel[0])][1])
        g = rec.geometry
        imgs = [group[i][1].image for i in sel]
        good = [k for k, im in enumerate(imgs) if im.shape == self._frame_shape and im.dtype == np.uint8]
        self.counts["frames_bad_shape"] = self.counts.get("frames_bad_shape", 0) + len(imgs) - len(good)
        if not good:
            return 0
        sel, ts = sel[good], times[sel[good]]
        # recon's sampling (recon.image_pooling), each frame pooled before the stack: no copy of the fine frames
        stack = np.stack([self.pooling.apply(imgs[k][None])[0] for k in good])
        rec.add_frames(ts, stack)
        if self.hooks.on_frames is not None:
            self.hooks.on_frames(g, ts, stack, rec.last_returns)
        dt = time.perf_counter() - t_start
        self.times.add("reconstruction", dt / sel.size, sel.size)
        self.counts["frames_processed"] += int(sel.size)
        self._t_last = max(self._t_last, float(ts.max()))
        if self.hooks.clock is not None:
            now = self.hooks.clock()
            for i in sel:  # from the frame's receipt (its event time is its ping's)
                _, fr = group[int(i)]
                self.times.add("frame_end_to_end", (now - (fr.received_ns or group[int(i)][0])) * 1e-9)
        self._poll_when_due(rec)
        return int(sel.size)

    def _reconstructor(self, first: SonarPayload) -> Reconstructor:
        """Recon, made with the first usable frame's beam table, window and range lines (an Oculus sends those of
        its range setting), pooled to recon's sampling (:mod:`recon.image_pooling`: an M750d's 512 x 4000 pings)."""
        if self.rec is None:
            frames = sonar_geometry(self.setup, first.azimuths, first.window, n_bins=first.image.shape[0])
            self._frame_shape = (frames.n_bins, frames.n_beams)
            self.pooling = ImagePooling.for_geometry(frames)
            self.geometry = self.pooling.geometry(frames)
            self.rec = Reconstructor(self.geometry, self.nav, self.recon_config,
                                     dvl_max_pitch=np.radians(self.config.max_pitch_deg))
        return self.rec

    def _poll_when_due(self, rec: Reconstructor) -> None:
        """Finalize and emit the objects the vehicle is past, once per ``poll_s`` of mission time."""
        k = math.floor(self._t_last / self.config.poll_s)
        if k <= self._poll_k:
            return
        self._poll_k = k
        t0 = time.perf_counter()
        pos, _ = self.nav.pose_at(self._t_last)
        objs = rec.poll(pos[0], self._t_last)
        self.counts["polls"] += 1
        self.times.add("clustering", time.perf_counter() - t0)
        self._emit(objs)

    # ------------------------------------------------------------------ objects
    def _emit(self, objects: list[DetectedObject], final: bool = False) -> None:
        """Classify ``objects``; report those that are not clutter, located in W (:class:`DetectionStore`).
        ``final``: the end-of-mission classification of objects already reported (no update counted)."""
        if not objects:
            return
        t0 = time.perf_counter()
        labels = self.labeller.label(objects, self.store.reported, final)
        if self.labeller.enabled:
            self.times.add("classification", (time.perf_counter() - t0) / len(objects), len(objects))
        epoch = (self.t0_ns or 0) * 1e-9
        for o, (c, s) in zip(objects, labels, strict=True):
            if c == CLUTTER:  # not an object: counted, not reported (a later pass may make it one)
                continue
            shift = self.georef.shift(0.5 * (float(o.t_first) + float(o.t_last)), corrected=False)[0]
            det = make_detection(o, c, s, shift, epoch)
            if not self.store.put(det, shift) and not final:
                self.counts["updates"] = self.counts.get("updates", 0) + 1
            if not final:
                self.strip_picker.pick(float(o.t_first), self.nav)
            if self.hooks.on_detection is not None:
                self.hooks.on_detection(det)

    def finish(self) -> list[Detection]:
        """End of the mission: process what is buffered, then every remaining object is final."""
        if self._finished:
            return self.detections
        self._finished = True
        self.advance(None)
        if self.rec is not None:
            t0 = time.perf_counter()
            objs = self.rec.finish()
            self.times.add("clustering", time.perf_counter() - t0)
            self._emit(objs)
            self._emit(self.labeller.take_deferred(), final=True)  # final classes on the final clouds
        self.store.finalize((self.t0_ns or 0) * 1e-9)
        return self.detections

    # ------------------------------------------------------------------ reporting
    def recon_stats(self) -> dict[str, Any]:
        rec = self.rec
        return {**self.counts, "nav_samples": dict(self.nav.samples), "nav_late_samples": self.nav.late,
                "frames_with_points": rec.frames_with_points if rec else 0, "points": rec.points_total if rec else 0,
                "seabed_removed": rec.seabed_removed if rec else 0, "objects": len(self.detections),
                "interfered_frames": rec.interfered_frames if rec else 0,
                "shadow_heights": dict(rec.shadows.outcomes) if rec else {},
                "beam_edge_deg": round(float(np.degrees(rec.beam_edge.half)), 3) if rec else None,
                "rejected_clutter": len(self.labeller.clutter),
                "rejected_not_objects": {**(dict(getattr(rec, "rejected", {})) if rec else {}),
                                         "clutter": len(self.labeller.clutter)}}

    def track(self, step: int = 5) -> np.ndarray:
        """Vehicle positions in W (corrected for drift once the mission is finished)."""
        t, pos = self.nav.positions(step)
        return pos + self.georef.shift(t, corrected=self._finished) if t.size else pos

    def track_table(self, step: int = 5) -> dict[str, np.ndarray]:
        """The columns of ``track.csv`` (:meth:`auvlink.pipeline.georef.Georef.track_table`)."""
        return self.georef.track_table(self.nav, (self.t0_ns or 0) * 1e-9, self._finished, step)

    def poses(self, rate_hz: float = 10.0) -> Poses:
        """The navigation solution in W at most ``rate_hz`` (the grid times the navigator answers for;
        with the GNSS anchor, and the drift correction once the mission is finished, as :meth:`track`)."""
        t, _ = self.nav.positions(1)
        if t.size:
            t = t[np.r_[True, np.diff(np.floor(t * rate_hz)) > 0]]
            t = t[self.nav.covered(t)]
        if not t.size:
            return Poses.empty()
        pos, rot = self.nav.pose_at(t)
        return Poses(t, pos + self.georef.shift(t, corrected=self._finished), rot.as_quat())

    def highlight_points(self) -> np.ndarray:
        """Every highlight-extension point in W (with the anchor; the drift correction is per detection)."""
        if self.rec is None:
            return np.zeros((0, 3))
        pts = self.rec.raw_points
        return pts + self.georef.shift(0.0, corrected=False)[0] if len(pts) else pts
