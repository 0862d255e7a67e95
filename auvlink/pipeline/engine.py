"""The streaming engine: samples in time order -> causal navigation -> recon -> clusters -> classes.

One engine serves ``auvlink live`` (fed from the drivers) and ``auvlink replay`` / ``demo`` (fed from
the log). :meth:`Engine.feed` buffers decoded samples; :meth:`Engine.advance` releases those older
than a watermark (live: every driver has handed over everything it received before it; replay: the
time of the sample being read), in ``(receive time, arrival)`` order:

1. navigation samples go to :class:`recon.nav_stream.CausalNavigator` (a pose at t uses samples up
   to t only, and is the same number however the samples were grouped);
2. sonar frames go to :class:`recon.reconstructor.Reconstructor` in groups of ``frame_block`` frames
   (it pulls the DVL seabed points up to the group's last frame from the navigator), so the result depends
   on the samples and the settings only, never on when they arrived; frames before the navigation starts or more
   than ``max_extrapolation_s`` past it are skipped and counted;
3. every ``poll_s`` of mission time the streaming clusterer finalizes the objects the vehicle is
   past; each is classified at once and handed to ``on_detection``, unless the classifier calls it
   ``clutter`` (not an object: seabed texture that survived the seabed removal; a model with that
   output, :mod:`classify.labels`): then it is counted (``rejected_clutter`` in the stats), not reported.
   A later pass fused into a rejected one (same id) is classified afresh and reported if it is an
   object now; an object once reported stays one (its updates get the best object class);
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
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from auvlink.geodesy import Datum
from auvlink.pipeline.engine_config import EngineConfig, default_recon_config
from auvlink.pipeline.frame_gate import survey_frames
from auvlink.pipeline.georef import Georef
from auvlink.pipeline.latency import StageTimes
from auvlink.pipeline.nav_inputs import Event, NavAdaptor, SonarPayload
from auvlink.pipeline.object_labels import ObjectLabeller, make_detection
from auvlink.pipeline.results import Detection, Poses, StripFrame
from auvlink.pipeline.setup import MissionSetup, nav_config, sonar_geometry
from auvlink.records import Sample
from classify.labels import CLUTTER
from recon.cluster import DetectedObject, dbscan_labels
from recon.nav import pressure_to_depth
from recon.nav_stream import CausalNavigator
from recon.reconstructor import ReconConfig, Reconstructor
from recon.sonar_geometry import SonarGeometry

#: s: the strip frame of an object is the one this long after its first highlight return: at the survey speed
#: (1.5 m/s) the vehicle has closed 1.2 m, so the object lies inside the range window, not on its far edge
STRIP_AFTER_FIRST_S = 0.8

#: ``on_frames(geometry, times, images, returns)``: frames just reconstructed (mission times s, (F, bins,
#: beams) uint8) and their highlight returns ((frame, beam, row) arrays, :attr:`Reconstructor.last_returns`)
FramesObserver = Callable[[SonarGeometry, npt.NDArray[np.float64], npt.NDArray[np.uint8],
                           tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.int64]]], None]


class Engine:
    """See the module docstring. ``clock`` (ns, the drivers' clock) enables end-to-end frame latency."""

    def __init__(self, setup: MissionSetup, config: EngineConfig | None = None, *, t0_ns: int | None = None,
                 recon_config: ReconConfig | None = None, classify: bool = True, model: Path | None = None,
                 on_detection: Callable[[Detection], None] | None = None,
                 clock: Callable[[], int] | None = None, strip_frames: int = 6, ring_frames: int = 200,
                 on_frames: FramesObserver | None = None, clutter_threshold: float | None = None) -> None:
        self.setup = setup
        self.config = config or EngineConfig()
        self.t0_ns = t0_ns
        self.recon_config = recon_config or default_recon_config()
        self.nav = CausalNavigator(nav_config(setup), self.config.max_extrapolation_s)
        self.adaptor = NavAdaptor()
        gm = setup.gnss_mounting
        self.georef = Georef(Datum.of_site(setup.site), gm.xyz if gm is not None else (0.0, 0.0, 0.0), gm is not None)
        self._applied: dict[int, np.ndarray] = {}  # detection id -> the D -> W shift it was handed on with
        self.times = StageTimes()
        self.detections: list[Detection] = []
        self.strip: list[StripFrame] = []
        self.counts = {"frames": 0, "frames_processed": 0, "frames_without_navigation": 0, "polls": 0}
        self.rec: Reconstructor | None = None
        self.geometry: SonarGeometry | None = None
        self.labeller = ObjectLabeller(classify, model, clutter_threshold)
        self._on_detection, self._clock = on_detection, clock
        self._on_frames = on_frames
        self._buf: list[Event] = []
        self._det_index: dict[int, int] = {}  # detection id -> its place in self.detections
        self._frames: list[tuple[int, SonarPayload]] = []
        self._ring: deque[tuple[float, npt.NDArray[np.uint8]]] = deque(maxlen=ring_frames)
        self._strip_max = strip_frames
        self._poll_k = -1
        self._t_last = -math.inf
        self._finished = False

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
        ev = self.adaptor.route(sample)
        if ev is not None:
            if self.t0_ns is None:
                self.t0_ns = ev.t_ns
            self._buf.append(ev)

    def _t(self, t_ns: int) -> float:
        return (t_ns - (self.t0_ns or 0)) * 1e-9

    def advance(self, watermark_ns: int | None = None) -> int:
        """Process every buffered event older than ``watermark_ns`` (all with None); returns frames done."""
        if not self._buf:
            return self._run_frames(final=watermark_ns is None)
        if watermark_ns is None:
            out, self._buf = self._buf, []
        else:
            out = [e for e in self._buf if e.t_ns < watermark_ns]
            if len(out) != len(self._buf):
                self._buf = [e for e in self._buf if e.t_ns >= watermark_ns]
            else:
                self._buf = []
        out.sort(key=lambda e: (e.t_ns, e.seq))
        self._navigate(out)
        self._frames.extend((e.t_ns, e.payload) for e in out if e.kind == "sonar")
        return self._run_frames(final=watermark_ns is None)

    def _navigate(self, events: list[Event]) -> None:
        t0 = time.perf_counter()
        d, g, p = self.adaptor.nav_inputs(events, self.t0_ns or 0)
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
            self.georef.on_fix(self._t(e.t_ns), e.payload, self.nav)
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
        t_start = time.perf_counter()
        self.counts["frames"] += len(group)
        times = np.array([self._t(t) for t, _ in group])
        ok = survey_frames(self.nav, times, self.config, self.counts)
        for (_, fr), t in zip(group, times, strict=True):
            self._ring.append((float(t), fr.image))
        if not ok.any():
            return 0
        sel = np.flatnonzero(ok)
        if self.rec is None:
            first = group[int(sel[0])][1]
            self.geometry = sonar_geometry(self.setup, first.azimuths, first.window)
            self.rec = Reconstructor(self.geometry, self.nav, self.recon_config,
                                     dvl_max_pitch=np.radians(self.config.max_pitch_deg))
        g = self.rec.geometry
        imgs = [group[i][1].image for i in sel]
        good = [k for k, im in enumerate(imgs) if im.shape == (g.n_bins, g.n_beams) and im.dtype == np.uint8]
        self.counts["frames_bad_shape"] = self.counts.get("frames_bad_shape", 0) + len(imgs) - len(good)
        if not good:
            return 0
        sel, ts = sel[good], times[sel[good]]
        stack = np.stack([imgs[k] for k in good])
        self.rec.add_frames(ts, stack)
        if self._on_frames is not None:
            self._on_frames(g, ts, stack, self.rec.last_returns)
        dt = time.perf_counter() - t_start
        self.times.add("reconstruction", dt / sel.size, sel.size)
        self.counts["frames_processed"] += int(sel.size)
        self._t_last = max(self._t_last, float(ts.max()))
        if self._clock is not None:
            now = self._clock()
            for i in sel:
                self.times.add("frame_end_to_end", (now - group[int(i)][0]) * 1e-9)
        k = math.floor(self._t_last / self.config.poll_s)
        if k > self._poll_k:
            self._poll_k = k
            t0 = time.perf_counter()
            pos, _ = self.nav.pose_at(self._t_last)
            objs = self.rec.poll(pos[0], self._t_last)
            self.counts["polls"] += 1
            self.times.add("clustering", time.perf_counter() - t0)
            self._emit(objs)
        return int(sel.size)

    # ------------------------------------------------------------------ objects
    def _emit(self, objects: list[DetectedObject]) -> None:
        if not objects:
            return
        t0 = time.perf_counter()
        labels = self.labeller.label(objects, self._det_index)
        if self.labeller.enabled:
            self.times.add("classification", (time.perf_counter() - t0) / len(objects), len(objects))
        epoch = (self.t0_ns or 0) * 1e-9
        for o, (c, s) in zip(objects, labels, strict=True):
            if c == CLUTTER:  # not an object: counted, not reported (a later pass may make it one)
                continue
            shift = self.georef.shift(0.5 * (float(o.t_first) + float(o.t_last)), corrected=False)[0]
            det = make_detection(o, c, s, shift, epoch)
            self._locate(det, shift)
            k = self._det_index.get(det.id)
            if k is None:  # a new object
                self._det_index[det.id] = len(self.detections)
                self.detections.append(det)
            else:  # a later pass fused into it (recon.fusion): the update replaces it, same id
                self.detections[k] = det
                self.counts["updates"] = self.counts.get("updates", 0) + 1
            self._pick_strip(float(o.t_first))
            if self._on_detection is not None:
                self._on_detection(det)

    def _locate(self, det: Detection, shift: np.ndarray, correction: np.ndarray | None = None) -> None:
        self._applied[det.id] = shift
        self.georef.locate(det, correction)

    def _georeference_final(self) -> None:
        """End of the mission: every detection to the corrected track (closure error distributed)."""
        self.georef.finalize(self.detections, self._applied, (self.t0_ns or 0) * 1e-9)

    def _pick_strip(self, t_first: float) -> None:
        if len(self.strip) >= self._strip_max or not self._ring:
            return
        ts = np.array([t for t, _ in self._ring])
        i = int(np.argmin(np.abs(ts - (t_first + STRIP_AFTER_FIRST_S))))
        t, img = self._ring[i]
        if not self.nav.covered(t)[0] or any(s.t == t for s in self.strip):
            return
        pos, rot = self.nav.pose_at(t)
        self.strip.append(StripFrame(t, img, pos, rot, self.nav.altitude_at(t)))

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
        self._georeference_final()
        return self.detections

    # ------------------------------------------------------------------ reporting
    def recon_stats(self) -> dict[str, Any]:
        rec = self.rec
        return {**self.counts, "nav_samples": dict(self.nav.samples), "nav_late_samples": self.nav.late,
                "frames_with_points": rec.frames_with_points if rec else 0, "points": rec.points_total if rec else 0,
                "seabed_removed": rec.seabed_removed if rec else 0, "objects": len(self.detections),
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
