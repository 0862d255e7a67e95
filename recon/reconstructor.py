"""The reconstruction: sonar frames + poses -> object points -> objects (:class:`Reconstructor`).

:class:`Reconstructor` consumes frames (time, (n_bins, n_beams) uint8 image) and a pose source (a
:class:`recon.trajectory.Trajectory`, a :class:`recon.nav_stream.CausalNavigator`, or anything with ``pose_at``
and ``altitude_at``). A batch of frames passes recon's stages once each, in order:

1. **onset** (:mod:`recon.onset_stage`): poses at the frame times, the expected seabed onset per beam and its
   correction by the seabed returns, the frame's threshold;
2. **returns** (:func:`recon.highlight.first_returns`): per column the first return before the onset (with
   calibration, none until the seabed's level has been measured: :attr:`recon.beam_edge.BeamEdge.level`);
3. **points** (:func:`recon.highlight.project`, :func:`recon.range_arcs.arc_columns`): those returns on the
   highlight ray, with their range arcs;
4. **seabed** (:mod:`recon.seabed_evidence`): the DVL's seabed points pulled from the pose source, the seabed
   returns and the highlight points into the seabed memory (:mod:`recon.seabed_memory`);
5. **clusters** (:mod:`recon.object_stage`): the points wait for :meth:`Reconstructor.poll` (streaming) or
   :meth:`Reconstructor.finish` (batch), which remove the seabed, cluster and finalize the objects, each with its
   top's height from the acoustic shadows the frames showed beyond the onset (:mod:`recon.shadow`).

Pure computation: no ports, no files.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from recon.beam_edge import MIN_FRAMES, WINDOW_FRAMES, BeamEdge, frame_edge_profile
from recon.cluster import DetectedObject
from recon.echo_mosaic import EchoMosaic
from recon.errors import GeometryError
from recon.frames import check_attitude
from recon.highlight import (
    first_returns,
    interfered_rows,
    onset_rows,
    project,
    row_background,
    run_span_bins,
    thresholds_over,
)
from recon.object_stage import ObjectStage
from recon.onset_stage import OnsetStage
from recon.pattern_fall import FALL_FRACTIONS, PatternFall
from recon.range_arcs import arc_columns
from recon.recon_config import ReconConfig
from recon.seabed import SeabedModel
from recon.seabed_band import SEABED_BAND
from recon.seabed_evidence import add_seabed_returns, initial_dvl_points, pull_dvl_points
from recon.seabed_memory import SeabedMemory
from recon.seabed_texture import SEABED_TEXTURE, TexturedSeabed
from recon.shadow import ShadowTops
from recon.sidelobe import margin_levels, sidelobe_thresholds
from recon.sonar_geometry import SonarGeometry

__all__ = ["PoseSource", "ReconConfig", "Reconstructor"]

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]


class PoseSource(Protocol):
    def pose_at(self, t: ArrayLike) -> tuple[F64, Rotation]: ...

    def altitude_at(self, t: ArrayLike) -> F64: ...


class Reconstructor:
    """Turns frames into highlight-extension points and those into objects; see the module doc.

    ``dvl_max_pitch`` (rad): DVL seabed points pulled from a streaming pose source while the vehicle pitched more
    are left out (diving or climbing, the altitude is far from the seabed under the vehicle)."""

    def __init__(self, geometry: SonarGeometry, poses: PoseSource, config: ReconConfig | None = None,
                 seabed_points: ArrayLike | None = None, *, dvl_max_pitch: float = np.inf) -> None:
        self.geometry = geometry
        self.nominal_geometry = geometry
        #: the effective lower edge of the fan, from the seabed onset against the DVL altitude (recon.beam_edge)
        self.beam_edge = BeamEdge(0.5 * geometry.spread)
        self.pattern_fall = PatternFall(WINDOW_FRAMES, MIN_FRAMES)  # the pattern beyond the edge (recon.pattern_fall)
        self.mosaic = EchoMosaic()  # the seabed band's echo over the seabed's (recon.echo_mosaic)
        self.shadows = ShadowTops()  # the tops of the objects' acoustic shadows (recon.shadow)
        self.poses = poses
        self.config = config or ReconConfig()
        self.dvl_max_pitch = dvl_max_pitch
        self.memory = SeabedMemory(self.config.seabed, SEABED_TEXTURE)  # seabed samples (recon.seabed_memory)
        self._onsets = OnsetStage(geometry, self.config, self.memory)
        self._objects = ObjectStage(self.config, self.memory, geometry.spread)
        if self.config.calibrate and self.config.below_edge:
            self._objects.below_edge = self._below_edge
        if self.config.calibrate and self.config.shadow_height:
            self._objects.shadow_reading = self.shadows.reading
        self.frames = 0
        self.frames_with_points = 0
        #: frames with a band bright across most of the fan before the seabed (interference; no points from it)
        self.interfered_frames = 0
        self.points_total = 0
        self._t_last = -np.inf
        #: the first returns of the last :meth:`add_frames` call: (frame index in that call, beam, row) arrays
        #: (what a viewer marks on the frames)
        self.last_returns: tuple[I64, I64, I64] = (np.zeros(0, np.int64),) * 3
        initial = initial_dvl_points(poses, seabed_points)
        if initial is not None:
            self.add_seabed_points(initial)

    def add_seabed_points(self, points: ArrayLike) -> None:
        """Seabed points (the DVL's bottom points, world NED m) for the tiled planes and the texture grid."""
        self.memory.add(points)

    def add_frame(self, t: float, image: NDArray[np.uint8]) -> int:
        """One frame; returns the number of highlight-extension points it gave."""
        return self.add_frames(np.array([t], dtype=np.float64), np.asarray(image)[None])

    def add_frames(self, times: ArrayLike, images: NDArray[np.uint8]) -> int:
        """A stack of frames (F, n_bins, n_beams) at ``times`` (F,), through the stages of the module doc; returns
        the points added."""
        g, cfg = self.geometry, self.config
        ts = np.asarray(times, dtype=np.float64).reshape(-1)
        imgs = np.asarray(images)
        if imgs.dtype != np.uint8 or imgs.shape != (ts.size, g.n_bins, g.n_beams):
            raise GeometryError(f"expected uint8 frames {(ts.size, g.n_bins, g.n_beams)}, "
                                f"got {imgs.dtype} {imgs.shape}")
        if ts.size == 0:  # an empty batch (e.g. the tail of a replay): nothing to add
            return 0
        dvl = pull_dvl_points(self.poses, float(ts.max()), self.dvl_max_pitch)
        if dvl is not None:
            self.add_seabed_points(dvl)
        pos, rot = self.poses.pose_at(ts)
        check_attitude(rot)
        alt = self.poses.altitude_at(ts)
        g, planes = self._effective_geometry(imgs, pos, rot, alt)
        # the grey level at which the seabed shows at the effective edge (recon.beam_edge): no return is fainter
        floor = self.beam_edge.level if cfg.calibrate else float("nan")
        onsets = self._onsets.run(self.frames, imgs, pos, rot, alt, floor)  # 1. onset
        if planes is not None and cfg.below_edge:
            self.mosaic.add(imgs, g, onsets.onset, pos, rot, *planes)
        if planes is not None and cfg.shadow_height:
            self.shadows.add(imgs, g, onsets.onset, pos, rot, *planes)
        hc = cfg.highlight
        limits = onset_rows(g, onsets.onset, hc.margin_m)
        if cfg.calibrate and not np.isfinite(floor):
            # the seabed's level not measured yet (no seabed onset in the frames so far: the surface, the dive):
            # no grey level a return must reach, no effective edge to place it on (recon.beam_edge): no returns
            limits = np.zeros_like(limits)
        thr = self._row_thresholds(imgs, onsets.row_threshold, limits) if cfg.calibrate else onsets.row_threshold
        fi, bi, ri = first_returns(imgs, limits, thr, hc, run_span_bins(hc, g.bin_size))  # 2. returns
        self.last_returns = (fi, bi, ri)
        pts = np.asarray(project(g, fi, bi, ri, pos, rot, hc.geometry, hc.dtype), dtype=np.float64)  # 3. points
        arcs = arc_columns(g, fi, bi, ri, pos, rot) if cfg.front_slope else np.zeros((fi.size, 0))
        add_seabed_returns(self.memory, g, SEABED_BAND, hc.margin_m, SEABED_TEXTURE.enabled, self.frames, onsets,
                           (fi, bi, ri), pos, rot)  # 4. seabed
        self.memory.add_highlights(pts)
        self._objects.add(pts, ts[fi], arcs)  # 5. clusters, at the next poll
        self.frames += ts.size
        self.frames_with_points += int(np.unique(fi).size)
        self.points_total += int(fi.size)
        self._t_last = max(self._t_last, float(ts.max(initial=-np.inf)))
        return int(fi.size)

    def _below_edge(self, points: F64) -> float:
        """Extra elevation (rad) below the edge at which an object of these points was seen: its brightness over
        the seabed (:mod:`recon.echo_mosaic`) through the pattern's measured fall (:mod:`recon.pattern_fall`)."""
        return float(self.pattern_fall.extra(self.mosaic.excess(points)))

    def _row_thresholds(self, imgs: NDArray[np.uint8], background: F64, limits: I64) -> F64:
        """(F, bins) thresholds of the highlight search: at least the onset stage's ``background`` (the water,
        the seabed's onset level), what stands out of its row across the fan (recon.highlight.row_thresholds) and
        out of the sidelobe arcs of the row's strongest return (recon.sidelobe); frames with a row bright across
        the fan before the onsets are counted as interfered."""
        g, cfg = self.geometry, self.config
        n_rows = min(g.n_bins, int(limits.max(initial=0)) + run_span_bins(cfg.highlight, g.bin_size))
        med, mad = row_background(imgs, n_rows)
        self.interfered_frames += int(interfered_rows(med, background, limits).any(axis=1).sum())
        thr = thresholds_over(background, med, mad)
        return sidelobe_thresholds(thr, imgs, n_rows, margin_levels(cfg.sidelobe_db, cfg.display_range_db))

    def _effective_geometry(self, imgs: NDArray[np.uint8], pos: F64, rot: Rotation, alt: F64
                            ) -> tuple[SonarGeometry, tuple[F64, F64] | None]:
        """The geometry with the fan's effective lower edge (:mod:`recon.beam_edge`) after this batch's frames
        (the spread whose upper half is the estimated edge; the fan's axis, tilt and beams unchanged) and the
        seabed plane each frame's edge was measured against (a point and the normal into the water, (F, 3) each;
        None without calibration)."""
        nominal = self.nominal_geometry
        if not self.config.calibrate:
            return nominal, None
        point, normal = self._onsets.seabed_planes(pos, rot, alt, frames_before=self.frames)
        # the fitted seabed's slope, through the DVL's bottom point under the vehicle: the altitude is measured
        # there, while a tile's depth is only as good as the points around it (0.15 m too deep at the edge of a
        # survey over a 5 deg slope, a 1.4 deg wider edge)
        dvl = np.column_stack([pos[:, :2], pos[:, 2] + alt])
        point = np.where(np.isfinite(alt)[:, None], dvl, point)
        fractions = FALL_FRACTIONS if self.config.below_edge else FALL_FRACTIONS[:1]
        profile, levels, steps = frame_edge_profile(imgs, nominal, pos, rot, point, normal, fractions)
        half = self.beam_edge.update(profile[:, 0], nominal.tilt, levels)
        if self.config.below_edge:
            self.pattern_fall.update(profile, steps)
        if half != 0.5 * self.geometry.spread:
            self.geometry = replace(nominal, spread=2.0 * half)
            self._onsets.geometry = self.geometry
            self._objects.spread = self.geometry.spread  # the arcs' elevations span the fan the points are placed in
        return self.geometry, (point, normal)

    @property
    def raw_points(self) -> F64:
        """Every highlight-extension point so far (before seabed removal), world NED."""
        return self._objects.raw_points

    @property
    def seabed_points(self) -> F64:
        """Every plane sample so far (the DVL's bottom points and the sparse sonar seabed returns), world NED."""
        return self.memory.points

    @property
    def seabed(self) -> TexturedSeabed | SeabedModel | None:
        """The seabed model of the latest poll."""
        return self._objects.seabed

    @property
    def rejected(self) -> dict[str, int]:
        """Clusters that were not objects, by reason (``too_wide``, ``too_low``, ``one_instant``)."""
        return self._objects.rejected

    @property
    def objects(self) -> list[DetectedObject]:
        """Every final object so far."""
        return self._objects.objects

    @property
    def seabed_removed(self) -> int:
        """Highlight points removed as seabed so far."""
        return self._objects.seabed_removed

    def seabed_depth_at(self, xy: ArrayLike, radius: float = 8.0) -> F64:
        """Depth (m, NED) of the seabed fitted under each horizontal position ``xy`` ``(n, 2)``
        (:meth:`recon.seabed_memory.SeabedMemory.depth_at`)."""
        return self.memory.depth_at(xy, radius)

    def fit_seabed(self, lo: F64, hi: F64) -> TexturedSeabed | SeabedModel | None:
        """The seabed over the box ``lo``-``hi`` (north, east): tiled planes from the seabed points around it, and
        on them the texture grid (:meth:`recon.seabed_memory.SeabedMemory.fit`)."""
        return self.memory.fit(lo, hi)

    def take_pending_points(self) -> tuple[F64, F64, F64]:
        """The points waiting for the next poll, less the seabed, with their times and arcs (the pending buffer
        emptied): what the clusterer would get (:meth:`recon.object_stage.ObjectStage.take_pending`)."""
        return self._objects.take_pending()

    def poll(self, vehicle_position: ArrayLike, t_now: float | None = None) -> list[DetectedObject]:
        """Streaming: objects the vehicle is past, final from now on (classify them now)."""
        return self._objects.poll(vehicle_position, self._t_last if t_now is None else t_now)

    def finish(self) -> list[DetectedObject]:
        """End of the mission: the remaining objects (all of them when :meth:`poll` was never used)."""
        return self._objects.finish()
