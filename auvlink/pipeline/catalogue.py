"""The site catalogue: the detections of many missions merged into physical objects, with change flags.

Input: one :class:`MissionData` per mission (its detections, its covered seabed, its start time).
All positions are brought into one horizontal frame (north, east in m; see :func:`common_frame`):

- **geographic** when every mission is georeferenced (its detections carry ``lat``/``lon``): the local
  NED frame of the earliest mission's datum; detections are placed from their latitude/longitude, and a
  mission's coverage is moved from its own datum's frame when the datums differ;
- **datum-less** otherwise: each mission's own local NED positions, taken as one frame (true when the
  missions started from the same point; the catalogue says so in its ``frame`` note).

**Merging** (:func:`merge`): missions are taken in time order (log start time); each mission's
detections are matched one-to-one to the objects found so far by a minimum-cost assignment
(:func:`scipy.optimize.linear_sum_assignment`) on the horizontal distance, gated at ``radius`` m
(:data:`MERGE_RADIUS_M`, default 1.5 m: the objects are 1-3 m across, dead reckoning drifts by about
1 m, and separate objects of a site lie farther apart), plus ``class_penalty`` m (0.5 m) when the
detection's class differs from the object's (so a detection goes to the object of its own class when two
are in reach, and one of another class merges only within ``radius - class_penalty``, 1.0 m). A detection left
unmatched starts a new object. An object's position is the mean of its sightings; its spread the RMS
and the largest distance of the sightings from that mean; its class the majority of its class votes
(ties: the higher summed score).

**Change flags** (:func:`flag`): the missions that *covered* an object are those whose covered area,
shrunk by ``edge_margin`` m, contains its position, and those that saw it. In time order: ``missing``
when the latest covering mission did not see it, ``new`` when the first covering mission did not see
it (it appeared in a later survey), else ``stable``. A mission that did not pass over an object says
nothing about it: "not covered" is not "not seen".
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

F64 = NDArray[np.float64]

MERGE_RADIUS_M = 1.5
CLASS_PENALTY_M = 0.5
EDGE_MARGIN_M = 0.5
LOCAL_NOTE = ("datum-less: positions are each mission's local NED metres (relative to its first navigation "
              "sample), merged as if the missions shared one origin; coordinates are [east, north] in m, not WGS84")


@dataclass
class MissionData:
    """One mission as the catalogue sees it. ``coverage``: a shapely geometry in the mission's own NED
    frame, x = east, y = north (m). Detections: dicts with ``id``, ``class``, ``score``, ``north``,
    ``east``, ``depth`` (m) and, when georeferenced, ``lat``, ``lon`` (WGS84 degrees)."""

    name: str
    start_ns: int
    detections: list[dict[str, Any]]
    coverage: Any
    datum: tuple[float, float] | None = None
    georeferenced: bool = False


@dataclass
class Sighting:
    mission: str
    det_id: int
    class_name: str
    score: float
    north: float
    east: float
    depth: float


@dataclass
class SiteObject:
    """A physical object of the site (common frame, m)."""

    id: int
    sightings: list[Sighting] = field(default_factory=list)
    status: str = "stable"
    covering: list[str] = field(default_factory=list)  # missions that covered it, in time order
    lat: float | None = None
    lon: float | None = None

    @property
    def north(self) -> float:
        return float(np.mean([s.north for s in self.sightings]))

    @property
    def east(self) -> float:
        return float(np.mean([s.east for s in self.sightings]))

    @property
    def depth(self) -> float:
        return float(np.nanmean([s.depth for s in self.sightings]))

    @property
    def votes(self) -> dict[str, int]:
        return dict(Counter(s.class_name for s in self.sightings).most_common())

    @property
    def class_name(self) -> str:
        score: dict[str, float] = {}
        for s in self.sightings:
            score[s.class_name] = score.get(s.class_name, 0.0) + s.score
        votes = self.votes
        return max(votes, key=lambda c: (votes[c], score[c]))

    def spread(self) -> tuple[float, float]:
        """RMS and largest horizontal distance (m) of the sightings from the object's position."""
        d = np.hypot(np.array([s.north for s in self.sightings]) - self.north,
                     np.array([s.east for s in self.sightings]) - self.east)
        return float(np.sqrt(np.mean(d * d))), float(d.max())

    @property
    def seen_in(self) -> list[str]:
        return [s.mission for s in self.sightings]


@dataclass
class Frame:
    """The catalogue's horizontal frame: geographic (a reference datum) or datum-less."""

    datum: tuple[float, float] | None
    note: str

    @property
    def geographic(self) -> bool:
        return self.datum is not None


def _geodesy() -> Any:
    """:mod:`auvlink.geodesy` (WGS84 <-> local NED by PROJ), loaded when a catalogue is geographic."""
    from auvlink import geodesy

    return geodesy


def common_frame(missions: list[MissionData]) -> Frame:
    """Geographic when every mission is georeferenced with a datum, else datum-less (see the module doc)."""
    geo = bool(missions) and all(m.georeferenced and m.datum is not None and
                                 all(d.get("lat") is not None and d.get("lon") is not None for d in m.detections)
                                 for m in missions)
    if not geo:
        return Frame(None, LOCAL_NOTE)
    first = min(missions, key=lambda m: m.start_ns)
    assert first.datum is not None
    return Frame(first.datum, f"WGS84; merged in the local NED frame of datum {first.datum[0]:.7f}, "
                              f"{first.datum[1]:.7f} (mission {first.name})")


def to_common(frame: Frame, mission: MissionData) -> tuple[list[Sighting], Any]:
    """A mission's sightings and coverage in the common frame."""
    dets = mission.detections
    north = np.array([float(d["north"]) for d in dets])
    east = np.array([float(d["east"]) for d in dets])
    cover = mission.coverage
    if frame.datum is not None and dets:
        ref = _geodesy().Datum(*frame.datum)
        ned = np.atleast_2d(ref.to_ned([d["lat"] for d in dets], [d["lon"] for d in dets]))
        north, east = ned[:, 0], ned[:, 1]
    if frame.datum is not None and mission.datum is not None and mission.datum != frame.datum:
        cover = _move(cover, mission.datum, frame.datum)
    sightings = [Sighting(mission.name, int(d.get("id", i)), str(d["class"]), float(d.get("score", 0.0)),
                          float(north[i]), float(east[i]), float(d.get("depth", np.nan)))
                 for i, d in enumerate(dets)]
    return sightings, cover


def _move(geom: Any, src: tuple[float, float], dst: tuple[float, float]) -> Any:
    """A geometry in (east, north) m of datum ``src`` into that of datum ``dst`` (through WGS84)."""
    import shapely

    geo = _geodesy()
    a, b = geo.Datum(*src), geo.Datum(*dst)

    def move(xy: F64) -> F64:
        lat, lon, _ = a.to_geodetic(np.column_stack([xy[:, 1], xy[:, 0], np.zeros(len(xy))]))
        ned = np.atleast_2d(b.to_ned(lat, lon))
        return np.column_stack([ned[:, 1], ned[:, 0]])

    return shapely.transform(geom, move)


def merge(sightings_by_mission: list[list[Sighting]], radius: float = MERGE_RADIUS_M,
          class_penalty: float = CLASS_PENALTY_M) -> list[SiteObject]:
    """Merge the missions' sightings (lists in time order) into objects (see the module doc)."""
    objects: list[SiteObject] = []
    big = 1e9
    for sightings in sightings_by_mission:
        if not sightings:
            continue
        if objects:
            pos = np.array([[o.north, o.east] for o in objects])
            cls = [o.class_name for o in objects]
            det = np.array([[s.north, s.east] for s in sightings])
            dist = np.hypot(det[:, None, 0] - pos[None, :, 0], det[:, None, 1] - pos[None, :, 1])
            cost = dist + class_penalty * np.array([[s.class_name != c for c in cls] for s in sightings])
            cost[cost > radius] = big  # another class: within radius - class_penalty only
            rows, cols = linear_sum_assignment(cost)
            pairs = {int(r): int(c) for r, c in zip(rows, cols, strict=True) if cost[r, c] < big}
        else:
            pairs = {}
        for i, s in enumerate(sightings):
            if i in pairs:
                objects[pairs[i]].sightings.append(s)
            else:
                objects.append(SiteObject(len(objects) + 1, [s]))
    return objects


def flag(objects: list[SiteObject], coverage: dict[str, Any], order: list[str],
         edge_margin: float = EDGE_MARGIN_M) -> None:
    """Set each object's ``covering`` missions and its ``status`` (new / missing / stable)."""
    import shapely

    inner = {m: g.buffer(-edge_margin) if not g.is_empty else g for m, g in coverage.items()}
    for g in inner.values():
        shapely.prepare(g)
    rank = {m: k for k, m in enumerate(order)}
    for o in objects:
        pt = shapely.Point(o.east, o.north)
        seen = set(o.seen_in)
        cov = {m for m, g in inner.items() if not g.is_empty and g.contains(pt)} | seen
        o.covering = sorted(cov, key=lambda m: rank[m])
        if o.covering[-1] not in seen:
            o.status = "missing"
        elif o.covering[0] not in seen:
            o.status = "new"
        else:
            o.status = "stable"


@dataclass
class Catalogue:
    frame: Frame
    missions: list[MissionData]  # in time order
    objects: list[SiteObject]
    radius: float
    edge_margin: float
    coverage: dict[str, Any]  # mission -> covered area in the common frame


def build_catalogue(missions: list[MissionData], radius: float = MERGE_RADIUS_M,
                    class_penalty: float = CLASS_PENALTY_M, edge_margin: float = EDGE_MARGIN_M) -> Catalogue:
    """Merge and flag (see the module doc); with a geographic frame every object gets ``lat``/``lon``."""
    ordered = sorted(missions, key=lambda m: (m.start_ns, m.name))
    frame = common_frame(ordered)
    per_mission, coverage = [], {}
    for m in ordered:
        s, c = to_common(frame, m)
        per_mission.append(s)
        coverage[m.name] = c
    objects = merge(per_mission, radius, class_penalty)
    flag(objects, coverage, [m.name for m in ordered], edge_margin)
    if frame.datum is not None and objects:
        lat, lon, _ = _geodesy().Datum(*frame.datum).to_geodetic(
            np.array([[o.north, o.east, 0.0] for o in objects]))
        for o, a, b in zip(objects, np.atleast_1d(lat), np.atleast_1d(lon), strict=True):
            o.lat, o.lon = float(a), float(b)
    return Catalogue(frame, ordered, objects, radius, edge_margin, coverage)
