"""Recon's last stage: highlight points waiting to be clustered, and the objects made of them.

Points (world NED m) wait with their frame times and range arcs (:mod:`recon.range_arcs`) until a poll
(streaming: :meth:`ObjectStage.poll`) or the end (batch: :meth:`ObjectStage.finish`). Then the seabed is removed
(the model fitted over the points' box by :meth:`recon.seabed_memory.SeabedMemory.fit`, the object points of
:func:`recon.poll_seabed.object_points`), the rest clustered (:mod:`recon.cluster`, streaming through
:class:`recon.cluster_stream.StreamingClusterer`), each object given the seabed depth under it and clutter
rejected (:func:`recon.poll_seabed.on_seabed`), and, with the front-slope correction on, each final object's
points moved up their arcs (:func:`recon.front_slope.replace_on_arcs`) and its centroid away from the sonar by
the far side it could not see (:func:`recon.far_side.far_side_centre`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from recon.cluster import DetectedObject, cluster, make_object
from recon.cluster_stream import StreamingClusterer
from recon.far_side import far_side_centre
from recon.front_slope import replace_on_arcs
from recon.poll_seabed import object_points, on_seabed
from recon.range_arcs import ARC_COLUMNS, arc_elevations, is_arc_record, points_at
from recon.recon_config import ReconConfig
from recon.seabed import SeabedModel
from recon.seabed_memory import SeabedMemory
from recon.seabed_texture import TexturedSeabed

F64 = NDArray[np.float64]


class ObjectStage:
    """Pending points, the streaming clusterer and the objects made so far (module docstring)."""

    def __init__(self, config: ReconConfig, memory: SeabedMemory, spread: float) -> None:
        self.config, self.memory, self.spread = config, memory, spread
        self._pending: list[tuple[F64, F64, F64]] = []
        self._raw: list[F64] = []
        self._stream: StreamingClusterer | None = None
        self.seabed: TexturedSeabed | SeabedModel | None = None  # the model of the latest poll
        self.rejected: dict[str, int] = {"too_wide": 0, "too_low": 0}
        self.objects: list[DetectedObject] = []
        self.seabed_removed = 0
        #: an object's extra elevation (rad) below the fan's edge from its points (recon.pattern_fall); None: none
        self.below_edge: Callable[[F64], float] | None = None

    def add(self, points: F64, times: F64, arcs: F64) -> None:
        """Points (N, 3), their frame times (N,) and range arcs (N, 10, or (N, 0) without the front-slope
        correction) to cluster at the next poll."""
        if times.size:
            self._pending.append((points, times, arcs))
            self._raw.append(points)

    @property
    def raw_points(self) -> F64:
        """Every highlight-extension point so far (before seabed removal), world NED."""
        return np.concatenate(self._raw) if self._raw else np.zeros((0, 3))

    def take_pending(self) -> tuple[F64, F64, F64]:
        """The pending points less the seabed (the pending buffer emptied)."""
        if not self._pending:
            p, t = np.zeros((0, 3)), np.zeros(0)
            e = np.zeros((0, ARC_COLUMNS if self.config.front_slope else 0))
        else:
            p = np.concatenate([a for a, _, _ in self._pending])
            t = np.concatenate([b for _, b, _ in self._pending])
            e = np.concatenate([c for _, _, c in self._pending])
        self._pending = []
        if not self.memory or p.shape[0] == 0:
            return p, t, e
        model = self.memory.fit(p[:, :2].min(axis=0), p[:, :2].max(axis=0))
        if model is None:
            return p, t, e
        self.seabed = model
        keep = object_points(p, model, self.config.seabed)
        self.seabed_removed += int((~keep).sum())
        return p[keep], t[keep], e[keep]

    def _on_seabed(self, objects: list[DetectedObject]) -> list[DetectedObject]:
        """Each object with the seabed depth under it, clutter rejected (:func:`recon.poll_seabed.on_seabed`)."""
        model = self.seabed
        if objects and isinstance(model, TexturedSeabed):
            lo = np.min([o.points[:, :2].min(axis=0) for o in objects], axis=0)
            hi = np.max([o.points[:, :2].max(axis=0) for o in objects], axis=0)
            if not model.covers(lo, hi):  # objects finalized away from this poll's new points
                model = self.memory.fit(lo, hi) or model
        return on_seabed(objects, model, self.rejected)

    def _finalize(self, objects: list[DetectedObject]) -> list[DetectedObject]:
        """Front-slope correction of final objects: points, extent, centroid (+ hidden far side)."""
        if not self.config.front_slope:
            return objects
        c, out = self.config, []
        for o in objects:
            pts, steepest = self._below_edge(o)
            f = make_object(o.id, replace_on_arcs(pts, o.extra, self.spread, c.front_slope_length, c.front_slope_width,
                                                  steepest=steepest), o.times, o.extra, o.passes)
            out.append(replace(f, centroid=far_side_centre(f.centroid, f.points, f.extra, c.far_side),
                               seabed_depth=o.seabed_depth))
        return out

    def _below_edge(self, o: DetectedObject) -> tuple[F64, F64 | None]:
        """The object's points re-placed on their arcs below the elevation each was placed at, by the extra
        elevation its brightness was seen at (:attr:`below_edge`), and those elevations (rad); the points
        unchanged and None when that is 0 or unknown."""
        if self.below_edge is None or not is_arc_record(o.extra, o.points.shape[0]):
            return o.points, None
        extra = self.below_edge(o.points)
        if not extra > 0.0:
            return o.points, None
        phi = arc_elevations(o.points, o.extra) + extra
        return points_at(o.extra, phi), phi

    def poll(self, vehicle_position: ArrayLike, t_now: float) -> list[DetectedObject]:
        """Streaming: the objects the vehicle at ``vehicle_position`` is past at ``t_now``, final from now on."""
        if self._stream is None:
            self._stream = StreamingClusterer(self.config.cluster)
        p, t, e = self.take_pending()
        self._stream.add(p, t, e)
        out = self._finalize(self._on_seabed(self._stream.poll(vehicle_position, t_now)))
        self.objects.extend(out)
        return out

    def finish(self) -> list[DetectedObject]:
        """End of the mission: the remaining objects (all of them when :meth:`poll` was never used)."""
        p, t, e = self.take_pending()
        if self._stream is None:
            out = cluster(p, t, self.config.cluster, e)
        else:
            self._stream.add(p, t, e)
            out = self._stream.flush()
        out = self._finalize(self._on_seabed(out))
        self.objects.extend(out)
        return out
