"""The report's interactive figures (plotly): the survey map, one 3D view per object, the timings.

Every figure is built here and turned into HTML by :mod:`auvlink.pipeline.report` (the plotly.js
library once per page, inline: the page opens offline). Map axes: east (x, m) and north (y, m) of
the world NED frame, equal scale; 3D views: east, north, up (m) about the object's centroid.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import plotly.graph_objects as go
from plotly.subplots import make_subplots
from scipy.spatial.transform import Rotation

from auvlink.pipeline.report_geo import ToGeodetic, add_geography
from auvlink.pipeline.results import Detection, MissionResult
from auvlink.pipeline.setup import TruthObject
from auvlink.pipeline.truth_scores import match, truth_in_result_frame
from auvlink.sim.object_meshes import CLASSES, mesh_for

MAP_POINTS = 4000  # highlight points drawn on the map at most (decimated evenly)
CLOUD_POINTS = 3000  # points drawn per object cloud at most
_PALETTE = ("#d62728", "#1f77b4", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22", "#2ca02c")


def class_colour(name: str) -> str:
    """A stable colour per class (the catalog's order; anything else grey)."""
    return _PALETTE[CLASSES.index(name) % len(_PALETTE)] if name in CLASSES else "#7f7f7f"


@dataclass(frozen=True)
class TruthMatch:
    """Detections against the truth (indices into ``result.detections`` / ``result.setup.truth``)."""

    pairs: list[tuple[int, int, float]]  # (detection, truth, horizontal distance m)
    truth_ne: np.ndarray  # (n, 2) the true objects' north, east in the detections' frame, m
    false: list[int]  # detections matching no true object
    missed: list[int]  # true objects no detection matched
    radius_m: float

    def truth_of(self, det_index: int) -> int | None:
        return next((j for i, j, _ in self.pairs if i == det_index), None)


def truth_match(result: MissionResult, radius: float = 1.0) -> TruthMatch | None:
    """The same greedy matching as :func:`auvlink.pipeline.truth_scores.score_detections`; None without truth."""
    truth = result.setup.truth
    if not truth:
        return None
    det_xy = np.array([d.position_ned[:2] for d in result.detections]).reshape(-1, 2)
    truth_xy = truth_in_result_frame(result)  # through the run's datum when geo-referenced, as the scores
    pairs = match(det_xy, truth_xy, radius)
    got_d, got_t = {p[0] for p in pairs}, {p[1] for p in pairs}
    return TruthMatch(pairs, truth_xy, [i for i in range(len(result.detections)) if i not in got_d],
                      [j for j in range(len(truth)) if j not in got_t], radius)


def _decimate(a: np.ndarray, n: int) -> np.ndarray:
    return a if len(a) <= n else a[np.linspace(0, len(a) - 1, n).astype(np.intp)]


def _det_hover(d: Detection, t0: float) -> str:
    n, e, z = d.position_ned
    return (f"<b>#{d.id} {d.class_name}</b> score {d.score:.2f}<br>north {n:.2f} m, east {e:.2f} m, "
            f"depth {z:.2f} m<br>{d.n_points} points, size {d.size[0]:.2f} x {d.size[1]:.2f} x {d.size[2]:.2f} m"
            f"<br>seen t = {d.t_first - t0:.1f} .. {d.t_last - t0:.1f} s" + _latlon(d))


def _latlon(d: Detection) -> str:
    lat, lon = d.latitude, d.longitude  # when geo-referenced
    return f"<br>{lat:.6f} N, {lon:.6f} E (WGS84)" if lat is not None and lon is not None else ""


def _bounds(result: MissionResult, truth_ne: np.ndarray) -> tuple[float, float, float, float]:
    """(east min, east max, north min, north max) of the track, detections and true objects, m."""
    ne = [np.asarray(result.track, dtype=np.float64).reshape(-1, 3)[:, :2]]
    ne += [np.array([d.position_ned[:2] for d in result.detections]).reshape(-1, 2), truth_ne.reshape(-1, 2)]
    pts = np.concatenate(ne)
    if not len(pts):
        return (-1.0, 1.0, -1.0, 1.0)
    return (float(pts[:, 1].min()), float(pts[:, 1].max()), float(pts[:, 0].min()), float(pts[:, 0].max()))


def survey_map_figure(result: MissionResult, matched: TruthMatch | None = None,
                      to_geodetic: ToGeodetic | None = None) -> go.Figure:
    """The survey map: navigation track, highlight points (decimated), detections (class, score on
    hover; colour by class), true objects when known (missed ones crossed), a scale bar; with the
    geo-referencing (``result.georef``, ``result.track_info``, ``to_geodetic``: NED at the site datum ->
    lat, lon, h) the GNSS fixes, the closure error and latitude/longitude axes
    (:func:`auvlink.pipeline.report_geo.add_geography`). East right, north up, equal scale; zoom and
    pan with the mouse. Everything the map shows is built here."""
    fig = go.Figure()
    hp = result.highlight_points
    if hp is not None and hp.size:
        p = _decimate(np.asarray(hp), MAP_POINTS)
        fig.add_trace(go.Scatter(x=p[:, 1], y=p[:, 0], mode="markers", name=f"highlight points ({len(hp)})",
                                 marker={"size": 3, "color": "#3182bd", "opacity": 0.55}, hoverinfo="skip"))
    if result.track.size:
        fig.add_trace(go.Scatter(x=result.track[:, 1], y=result.track[:, 0], mode="lines",
                                 name="navigation (dead reckoning)", line={"color": "#555", "width": 1.5},
                                 hovertemplate="north %{y:.1f} m<br>east %{x:.1f} m<extra>track</extra>"))
    truth = result.setup.truth
    truth_ne = matched.truth_ne if matched is not None else truth_in_result_frame(result)
    if truth:
        missed = set(matched.missed) if matched else set()
        for label, keep, symbol in (("true objects", False, "square-open"), ("missed objects", True, "x-thin-open")):
            idx = [j for j in range(len(truth)) if (j in missed) == keep]
            if not idx:
                continue
            objs, ne = [truth[j] for j in idx], truth_ne[idx]
            fig.add_trace(go.Scatter(
                x=ne[:, 1], y=ne[:, 0],
                mode="markers+text" if keep else "markers",  # names on the missed only: no crowded labels
                name=label, text=[t.class_name for t in objs], textposition="bottom center",
                textfont={"size": 10, "color": "#2ca02c" if not keep else "#000"},
                marker={"symbol": symbol, "size": 16, "color": "#2ca02c" if not keep else "#000",
                        "line": {"width": 2}},
                hovertext=[f"true {t.class_name}<br>north {p[0]:.2f} m, east {p[1]:.2f} m"
                           f"<br>heading {t.heading_deg:.0f} deg" for t, p in zip(objs, ne, strict=True)],
                hoverinfo="text"))
    false = set(matched.false) if matched else set()
    for name in sorted({d.class_name for d in result.detections}):
        idx = [i for i, d in enumerate(result.detections) if d.class_name == name]
        dets = [result.detections[i] for i in idx]
        fig.add_trace(go.Scatter(
            x=[d.position_ned[1] for d in dets], y=[d.position_ned[0] for d in dets], mode="markers",
            name=f"detected {name}", hovertext=[_det_hover(d, result.t0) for d in dets], hoverinfo="text",
            customdata=[d.id for d in dets],  # the page's click handler scrolls to the object's section
            marker={"size": 10, "color": class_colour(name),
                    "symbol": ["diamond" if i in false else "circle" for i in idx],
                    "line": {"width": 1, "color": "#000"}}))
    georef = result.georef
    title = add_geography(fig, _bounds(result, truth_ne), georef, result.track_info, to_geodetic)
    geo_axes = bool(georef.get("georeferenced")) and to_geodetic is not None
    fig.update_layout(title=f"{title}; detections: circle, false detections: diamond", height=660,
                      margin={"l": 60, "r": 90 if geo_axes else 20, "t": 110 if geo_axes else 50, "b": 50},
                      legend={"itemsizing": "constant", "x": 1.13 if geo_axes else 1.02},
                      xaxis={"title": "east [m]"},
                      yaxis={"title": "north [m]", "scaleanchor": "x", "scaleratio": 1},
                      hovermode="closest", template="plotly_white")
    return fig


def _mesh_trace(class_name: str, heading_deg: float) -> go.Mesh3d | None:
    """The class's reference mesh (simulator catalog; object frame x forward, y starboard, z down)
    turned by ``heading_deg`` about the vertical, as east/north/up about its centre."""
    if class_name not in CLASSES:
        return None
    v, f = mesh_for(class_name)
    ned = Rotation.from_euler("z", heading_deg, degrees=True).apply(np.array(v, dtype=np.float64))
    enu = np.column_stack([ned[:, 1], ned[:, 0], -ned[:, 2]])
    enu -= 0.5 * (enu.min(axis=0) + enu.max(axis=0))
    enu = enu.astype(np.float32)
    return go.Mesh3d(x=enu[:, 0], y=enu[:, 1], z=enu[:, 2], i=f[:, 0], j=f[:, 1], k=f[:, 2],
                     color=class_colour(class_name), opacity=1.0, flatshading=True,
                     name=f"reference {class_name}", hoverinfo="name")


def object_figure(det: Detection, truth: TruthObject | None = None) -> go.Figure:
    """One object: its point cloud (left, coloured by height) beside its class's reference mesh
    (right; turned to the true heading when the truth is known, else heading 0). Rotate with the mouse."""
    ref_class = truth.class_name if truth is not None else det.class_name
    heading = truth.heading_deg if truth is not None else 0.0
    fig = make_subplots(rows=1, cols=2, specs=[[{"type": "scene"}, {"type": "scene"}]], horizontal_spacing=0.02,
                        subplot_titles=(f"#{det.id}: {len(det.points)} points",
                                        f"reference {ref_class}" + (f", true heading {heading:.0f} deg"
                                                                     if truth is not None else "")))
    p = _decimate(np.asarray(det.points, dtype=np.float64), CLOUD_POINTS) - np.asarray(det.position_ned)
    up = -p[:, 2]
    fig.add_trace(go.Scatter3d(x=p[:, 1].astype(np.float32), y=p[:, 0].astype(np.float32), z=up.astype(np.float32),
                               mode="markers", name="points",
                               marker={"size": 2, "color": up.astype(np.float32), "colorscale": "Viridis"},
                               hovertemplate="east %{x:.2f}<br>north %{y:.2f}<br>up %{z:.2f} m<extra></extra>"),
                  row=1, col=1)
    mesh = _mesh_trace(ref_class, heading)
    extent = np.abs(p).max(axis=0) if len(p) else np.ones(3)  # N, E, D half-extents
    if mesh is not None:
        fig.add_trace(mesh, row=1, col=2)
        m = np.abs(np.column_stack([mesh.y, mesh.x, mesh.z])).max(axis=0)
        extent = np.maximum(extent, m)
    half = np.maximum(extent * 1.05, 0.25)  # the same box, hence the same scale, in both views
    aspect = half / half.max()
    scene = {"xaxis": {"title": "east [m]", "range": [-half[1], half[1]]},
             "yaxis": {"title": "north [m]", "range": [-half[0], half[0]]},
             "zaxis": {"title": "up [m]", "range": [-half[2], half[2]]},
             "aspectmode": "manual", "aspectratio": {"x": aspect[1], "y": aspect[0], "z": aspect[2]},
             "camera": {"eye": {"x": 1.4, "y": -1.4, "z": 1.0}}}
    fig.update_layout(height=420, margin={"l": 0, "r": 0, "t": 30, "b": 0}, showlegend=False,
                      scene=scene, scene2=scene)
    return fig


def timings_figure(result: MissionResult) -> go.Figure | None:
    """Time per stage (s, left) and per-item latency p50/p99 of each streaming stage (ms, log scale)."""
    items = [(k.removesuffix("_s"), float(v)) for k, v in result.timings.items() if k != "total_s"]
    lat = [(k, v) for k, v in result.latency.items() if v.get("p50_ms") is not None]
    if not items and not lat:
        return None
    fig = make_subplots(rows=1, cols=2, subplot_titles=(
        f"time per stage (total {result.timings.get('total_s', 0.0):.1f} s)", "latency per item [ms]"))
    fig.add_trace(go.Bar(y=[k for k, _ in items], x=[v for _, v in items], orientation="h", name="s", showlegend=False,
                         text=[f"{v:.2f} s" for _, v in items], marker_color="#1f77b4"), row=1, col=1)
    for q, colour in (("p50_ms", "#2ca02c"), ("p99_ms", "#ff7f0e")):
        fig.add_trace(go.Bar(y=[k for k, _ in lat], x=[v[q] for _, v in lat], orientation="h",
                             name=q.removesuffix("_ms"), marker_color=colour), row=1, col=2)
    fig.update_xaxes(type="log", row=1, col=2)
    fig.update_layout(height=320, barmode="group", margin={"l": 60, "r": 20, "t": 40, "b": 30},
                      template="plotly_white")
    return fig


def to_div(fig: go.Figure, div_id: str) -> str:
    """The figure as a ``<div>`` + script (no plotly.js: the page includes it once)."""
    config: dict[str, Any] = {"displaylogo": False, "responsive": True}
    height = fig.layout.height
    return str(fig.to_html(full_html=False, include_plotlyjs=False, div_id=div_id, config=config,
                           default_height=f"{height}px" if height else "100%"))
