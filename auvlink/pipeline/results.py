"""What a pipeline run produces: :class:`Detection` (one classified object), :class:`StripFrame` (a sonar
frame kept for the report), :class:`Poses` (the navigation solution), :class:`FanFrame` (a sonar frame
rendered for ``results.mcap``) and :class:`MissionResult` (everything of a live or replay run).

Plain data, imported by the engine, the runners (:mod:`auvlink.pipeline.process`,
:mod:`auvlink.pipeline.live`) and the outputs alike, so none of them imports another for its types.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from auvlink.pipeline.setup import MissionSetup
from recon.shape import OrientedBox, oriented_box
from recon.sonar_geometry import SonarGeometry

#: decimals of a written classifier score: a float32 network's last bits depend on the CPU's SIMD path
SCORE_DECIMALS = 4
#: decimals of a written position or distance in metres (0.1 mm, far below any sensor's resolution)
METRE_DECIMALS = 4


@dataclass
class Detection:
    """One classified object (world frame NED, m; times s since the UNIX epoch)."""

    id: int
    class_name: str
    score: float
    position_ned: tuple[float, float, float]
    size: tuple[float, float, float]
    n_points: int
    t_first: float
    t_last: float
    points: np.ndarray
    times: np.ndarray = field(default_factory=lambda: np.zeros(0))  # per point, s since the epoch
    #: where position_ned is: "site" (the datum, anchored to GNSS) or "first_navigation_sample"
    frame: str = "first_navigation_sample"
    latitude: float | None = None  # WGS84 deg, when georeferenced
    longitude: float | None = None
    drift_correction_ne: tuple[float, float] = (0.0, 0.0)  # m, applied at the end (closure error share)
    passes: tuple[tuple[float, float], ...] = ()  # time spans (s since the epoch) of the passes that saw it
    seabed_depth: float | None = None  # m, NED: the seabed under it (recon's model of the poll)
    shadow_height: float | None = None  # m: its top over the seabed from its acoustic shadows (recon.shadow)
    #: what recon measured of it besides its cloud (classify.decision.EVIDENCE; auvlink.pipeline.object_labels)
    evidence: tuple[float, ...] = ()

    @property
    def box(self) -> OrientedBox:
        """The oriented box of the points (principal horizontal axis; :mod:`recon.shape`)."""
        return oriented_box(self.points)

    def to_json(self, cloud: str) -> dict[str, Any]:
        """A line of ``detections.jsonl``: ``yaw_deg`` is the heading of the principal horizontal axis
        (deg clockwise from north, [0, 180)), ``length_m`` / ``width_m`` the spans along / across it."""
        box = self.box
        out = {"id": self.id, "class": self.class_name, "score": round(self.score, SCORE_DECIMALS),
               "position_ned": [round(v, METRE_DECIMALS) for v in self.position_ned],
               "size": [round(v, METRE_DECIMALS) for v in self.size], "n_points": self.n_points,
               "yaw_deg": round(box.yaw_deg, 2), "length_m": round(box.length_m, METRE_DECIMALS),
               "width_m": round(box.width_m, METRE_DECIMALS),
               "t_first": self.t_first, "t_last": self.t_last, "cloud": cloud, "frame": self.frame,
               "passes": [list(p) for p in self.passes],
               "seabed_depth": None if self.seabed_depth is None else round(self.seabed_depth, METRE_DECIMALS),
               "shadow_height_m": None if self.shadow_height is None else round(self.shadow_height, 3)}
        if self.latitude is not None and self.longitude is not None:
            out["lat"], out["lon"] = round(self.latitude, 9), round(self.longitude, 9)
            out["drift_correction_ne"] = [round(v, METRE_DECIMALS) for v in self.drift_correction_ne]
        return out


@dataclass(frozen=True)
class StripFrame:
    """A sonar frame kept for the report, with the pose it was processed with (mission time s)."""

    t: float
    image: np.ndarray
    position: np.ndarray  # (1, 3)
    rotation: Rotation  # (1) R_WB
    altitude: np.ndarray  # (1,)


@dataclass(frozen=True)
class Poses:
    """The navigation solution sampled for viewers: mission time (s), positions W (NED, m), R_WB as
    quaternions (x, y, z, w; scipy order)."""

    t: np.ndarray  # (n,)
    position: np.ndarray  # (n, 3)
    quat: np.ndarray  # (n, 4)

    @classmethod
    def empty(cls) -> Poses:
        return cls(np.zeros(0), np.zeros((0, 3)), np.zeros((0, 4)))


@dataclass(frozen=True)
class FanFrame:
    """A sonar frame rendered as a fan picture (PNG), the highlight returns marked (mission time s)."""

    t: float
    png: bytes
    returns: int  # highlight returns marked


@dataclass
class MissionResult:
    """Everything a run produced (live or replay)."""

    log: Path | None
    setup: MissionSetup
    detections: list[Detection]
    track: np.ndarray  # (n, 3) vehicle positions, world NED
    t0: float = 0.0  # s since the epoch of mission time 0
    strip: list[StripFrame] = field(default_factory=list)
    geometry: SonarGeometry | None = None  # the sonar's, when it had frames
    timings: dict[str, float] = field(default_factory=dict)
    latency: dict[str, dict[str, Any]] = field(default_factory=dict)
    replay_stats: dict[str, Any] = field(default_factory=dict)
    recon_stats: dict[str, Any] = field(default_factory=dict)
    loss: dict[str, Any] | str = ""  # replay: the log's loss report (JSON); live: why writing the log failed
    highlight_points: np.ndarray | None = None
    drops: dict[str, int] = field(default_factory=dict)
    events: list[dict[str, Any]] = field(default_factory=list)
    mode: str = "replay"
    engine: dict[str, Any] = field(default_factory=dict)
    t0_ns: int = 0  # ns since the epoch of mission time 0 (``t0`` exactly)
    poses: Poses = field(default_factory=Poses.empty)
    fan_frames: list[FanFrame] = field(default_factory=list)
    georef: dict[str, Any] = field(default_factory=dict)  # datum, anchor, closure, fix counts (Georef.summary)
    track_info: dict[str, np.ndarray] = field(default_factory=dict)  # the columns of track.csv
    clutter_scores: list[tuple[int, float]] = field(default_factory=list)  # (id, P(clutter)) per classification

    def loss_json(self) -> dict[str, Any]:
        """What the log lost, as one JSON object: replay gives the reader's loss report (``state``,
        ``messages_lost``, ``seconds_lost``, ``spans``, ...); live gives ``{}``, or ``state`` =
        ``write_failed`` with the reason when writing the log failed."""
        if isinstance(self.loss, dict):
            return self.loss
        return {"state": "write_failed", "summary": self.loss} if self.loss else {}
