"""Recon's last stage: highlight points waiting to be clustered, and the objects made of them.

Points (world NED m) wait with their frame times and range arcs (:mod:`recon.range_arcs`) until a poll
(streaming: :meth:`ObjectStage.poll`) or the end (batch: :meth:`ObjectStage.finish`). Then the seabed is removed
(the model fitted over the points' box by :meth:`recon.seabed_memory.SeabedMemory.fit`, the object points of
:func:`recon.poll_seabed.object_points`), the rest clustered (:mod:`recon.cluster`, streaming through
:class:`recon.cluster_stream.StreamingClusterer`), clusters seen at one instant dropped (:data:`ONE_INSTANT_S`),
each object given the seabed depth under it and clutter rejected (:func:`recon.poll_seabed.on_seabed`), and, with
the front-slope correction on, each final object's points moved up their arcs
(:func:`recon.front_slope.replace_on_arcs`) and its centroid away from the sonar by the far side it could not see
(:func:`recon.far_side.far_side_centre`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from recon.arc_consensus import consensus_points
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
from recon.shadow import ShadowReading

F64 = NDArray[np.float64]

#: the shortest ping interval of the sonars supported (s): the Oculus M-series' 40 pings/s (data sheet). A cluster
#: whose points' times span less was seen at one instant (one ping, or a burst of pings stamped on arrival by a
#: sonar without its own clock): an interference stripe or a misplaced burst, never an object on the seabed, which
#: stays in the fan while the vehicle crosses the fan's along-track footprint (metres: many pings at any supported
#: rate)
ONE_INSTANT_S = 0.025


def persistent(rejected: dict[str, int], objects: list[DetectedObject]) -> list[DetectedObject]:
    """The clusters seen over more than one instant (their points' times span :data:`ONE_INSTANT_S` or more); the
    others counted in ``rejected["one_instant"]``."""
    keep = [o for o in objects if o.t_last - o.t_first >= ONE_INSTANT_S]
    rejected["one_instant"] = rejected.get("one_instant", 0) + len(objects) - len(keep)
    return keep


class ObjectStage:
    """Pending points, the streaming clusterer and the objects made so far (module docstring)."""

    def __init__(self, config: ReconConfig, memory: SeabedMemory, spread: float) -> None:
        self.config, self.memory, self.spread = config, memory, spread
        self.nominal_spread = spread  # rad: the fan's data-sheet spread (``spread`` follows the effective edge)
        self._pending: list[tuple[F64, F64, F64]] = []
        #: points removed as seabed, tested again ``config.seabed.revisit_s`` later (:meth:`take_pending`)
        self._removed: tuple[F64, F64, F64] | None = None
        self._raw: list[F64] = []
        self._stream: StreamingClusterer | None = None
        self.seabed: TexturedSeabed | SeabedModel | None = None  # the model of the latest poll
        self.rejected: dict[str, int] = {"too_wide": 0, "too_low": 0, "one_instant": 0}
        self.objects: list[DetectedObject] = []
        self.seabed_removed = 0
        #: an object's extra elevation (rad) below the fan's edge from its points (recon.pattern_fall); None: none
        self.below_edge: Callable[[F64], float] | None = None
        #: the shadow reading of an object (its top height over the seabed, m, ...) from its points' footprint
        #: (recon.shadow); None: not measured
        self.shadow_reading: Callable[[F64], ShadowReading] | None = None

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

    def take_pending(self, final: bool = False) -> tuple[F64, F64, F64]:
        """The pending points less the seabed (the pending buffer emptied), with the removed points a later model
        puts above the seabed (:meth:`_revisit`: those removed ``config.seabed.revisit_s`` before the newest
        pending point, every one when ``final``)."""
        if not self._pending:
            p, t = np.zeros((0, 3)), np.zeros(0)
            e = np.zeros((0, ARC_COLUMNS if self.config.front_slope else 0))
        else:
            p = np.concatenate([a for a, _, _ in self._pending])
            t = np.concatenate([b for _, b, _ in self._pending])
            e = np.concatenate([c for _, _, c in self._pending])
        self._pending = []
        if not self.memory:
            return p, t, e
        if p.shape[0]:
            model = self.memory.fit(p[:, :2].min(axis=0), p[:, :2].max(axis=0))
            if model is None:
                return p, t, e
            self.seabed = model
            keep = object_points(p, model, self.config.seabed)
            self.seabed_removed += int((~keep).sum())
            due = self._due(None if final else float(t.max()))
            self._removed = _joined(self._removed, (p[~keep], t[~keep], e[~keep]))
            p, t, e = p[keep], t[keep], e[keep]
        else:
            due = self._due(None) if final else None
        if due is not None:
            p, t, e = _joined((p, t, e), self._revisit(*due, latest=p.shape[0] == 0))
        return p, t, e

    def _due(self, t_newest: float | None) -> tuple[F64, F64, F64] | None:
        """The removed points due for a second test (removed ``config.seabed.revisit_s`` or more before ``t_newest``;
        None: all), taken out of the store; None when there are none."""
        if self._removed is None:
            return None
        rp, rt, re = self._removed
        due = np.ones(rt.shape, bool) if t_newest is None else rt <= t_newest - self.config.seabed.revisit_s
        if not due.any():
            return None
        self._removed = rp[~due], rt[~due], re[~due]
        return rp[due], rt[due], re[due]

    def _revisit(self, p: F64, t: F64, e: F64, latest: bool) -> tuple[F64, F64, F64]:
        """Of points removed as seabed, those a seabed model fitted now over their box puts above it: the model under
        a point matures as the survey adds samples around it (the next lines, a crossing), and a low object its
        first fit followed (few cells around it at a line's start) stands out of the later one; points next to an
        object already emitted stay removed (an emitted object is not grown again). ``latest``: that
        model is the poll's (no new points were fitted), the one the objects are given their seabed from."""
        model = self.memory.fit(p[:, :2].min(axis=0), p[:, :2].max(axis=0))
        if model is None:
            return p[:0], t[:0], e[:0]
        if latest:
            self.seabed = model
        keep = object_points(p, model, self.config.seabed)
        if self._stream is not None:  # they recover lost objects; an object already emitted stays as it was
            keep &= ~self._stream.near_emitted(p)
        self.seabed_removed -= int(keep.sum())
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

    def _measured(self, objects: list[DetectedObject]) -> list[DetectedObject]:
        """Final objects with what their shadows say (:attr:`shadow_reading`): the reading and its top height."""
        if self.shadow_reading is None:
            return objects
        out = []
        for o in objects:
            r = self.shadow_reading(o.points)
            out.append(replace(o, shadow_height=r.height, shadow=r))
        return out

    def _below_edge(self, o: DetectedObject) -> tuple[F64, F64 | None]:
        """The object's points re-placed on their arcs below the elevation each was placed at, and those elevations
        (rad): where the arcs of their frames meet (``config.arc_consensus``, :mod:`recon.arc_consensus`), else by
        the extra elevation the object's brightness was seen at (:attr:`below_edge`); the points unchanged and None
        when neither applies or that extra is 0 or unknown."""
        if not is_arc_record(o.extra, o.points.shape[0]):
            return o.points, None
        if self.config.arc_consensus:
            return consensus_points(o.points, o.extra, o.times, self.nominal_spread, o.seabed_depth)
        if self.below_edge is None:
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
        found = persistent(self.rejected, self._stream.poll(vehicle_position, t_now))
        out = self._measured(self._finalize(self._on_seabed(found)))
        self.objects.extend(out)
        return out

    def finish(self) -> list[DetectedObject]:
        """End of the mission: the remaining objects (all of them when :meth:`poll` was never used)."""
        p, t, e = self.take_pending(final=True)
        if self._stream is None:
            out = cluster(p, t, self.config.cluster, e)
        else:
            self._stream.add(p, t, e)
            out = self._stream.flush()
        out = self._measured(self._finalize(self._on_seabed(persistent(self.rejected, out))))
        self.objects.extend(out)
        return out


def _joined(a: tuple[F64, F64, F64] | None, b: tuple[F64, F64, F64]) -> tuple[F64, F64, F64]:
    """Points, times and arcs of ``a`` (None: none) followed by those of ``b``."""
    if a is None:
        return b
    return np.concatenate([a[0], b[0]]), np.concatenate([a[1], b[1]]), np.concatenate([a[2], b[2]])
