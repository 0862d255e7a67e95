"""The survey map's geography (plotly): degree axes tied to the metric ones, fixes, closure, scale bar."""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go

from auvlink.pipeline.report_geo import add_geography, nice_length

LAT0, LON0 = 36.0, 129.4  # the datum
M_PER_DEG_LAT, M_PER_DEG_LON = 110_950.0, 90_180.0  # local scale near 36 N (linear is all the map needs)


def to_geodetic(ned: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return LAT0 + ned[:, 0] / M_PER_DEG_LAT, LON0 + ned[:, 1] / M_PER_DEG_LON, -ned[:, 2]


def test_nice_lengths() -> None:
    assert [nice_length(x) for x in (0.0, 0.9, 1.4, 3.2, 7.9, 18.0, 260.0)] == [1.0, 1.0, 1.0, 2.0, 10.0, 20.0, 200.0]


def test_degree_axes_sit_where_the_degrees_are() -> None:
    fig = go.Figure()
    georef = {"georeferenced": True, "datum": {"latitude": LAT0, "longitude": LON0}, "closure_m": 1.5,
              "closure_ne_m": [1.2, 0.9]}
    track = {"fixes": np.array([[0.0, -2.0, 1.0], [1.0, -1.0, 1.5]]), "north": np.array([0.0, 50.0]),
             "east": np.array([0.0, 10.0]), "correction_north": np.array([0.0, 1.2]),
             "correction_east": np.array([0.0, 0.9])}
    title = add_geography(fig, (0.0, 10.0, 0.0, 50.0), georef, track, to_geodetic)
    assert "36.00000 N, 129.40000 E" in title and "GNSS-anchored" in title
    lay = fig.layout
    assert lay.xaxis2.matches == "x" and lay.yaxis2.matches == "y" and lay.xaxis2.side == "top"
    for pos, label in zip(lay.xaxis2.tickvals, lay.xaxis2.ticktext, strict=True):
        assert abs(float(label) - (LON0 + pos / M_PER_DEG_LON)) < 1e-5 * 0.51  # to the printed digit
    for pos, label in zip(lay.yaxis2.tickvals, lay.yaxis2.ticktext, strict=True):
        assert abs(float(label) - (LAT0 + pos / M_PER_DEG_LAT)) < 1e-5 * 0.51
    assert len(lay.yaxis2.tickvals) >= 3
    names = [t.name for t in fig.data]
    assert "GNSS fixes (antenna)" in names and any(n and n.startswith("closure error 1.50 m") for n in names)
    arrow = next(a for a in lay.annotations if a.showarrow)
    assert (arrow.x, arrow.y, arrow.ax, arrow.ay) == (10.0, 50.0, 10.0 - 0.9, 50.0 - 1.2)
    bar = lay.shapes[0]
    assert bar.x1 - bar.x0 == 10.0 and bar.x0 > 10.0  # a 10 m scale bar on a map 50 m high, beside it


def test_without_gnss_the_map_says_positions_are_relative() -> None:
    fig = go.Figure()
    title = add_geography(fig, (0.0, 40.0, 0.0, 40.0), {}, {}, None)
    assert "relative to the first navigation sample" in title and "xaxis2" not in fig.layout.to_plotly_json()


def test_the_object_in_the_fan_golden() -> None:
    from auvlink.pipeline.report_frames import object_in_fan
    from auvlink.pipeline.results import Detection

    det = Detection(0, "box", 0.9, (8.0, 1.0, 20.0), (1.2, 0.8, 0.6), 10, 0.0, 1.0, np.zeros((10, 3)))
    x, y = object_in_fan(det, (0.0, 0.0, 15.0, 0.0))  # heading north: 8 m ahead, 1 m to starboard, 5 m below
    assert np.allclose((x, y), (1.0, np.sqrt(89.0)))  # x = starboard; y = the rest of the 9.487 m slant range
    det.position_ned = (1.0, 8.0, 20.0)
    x, y = object_in_fan(det, (0.0, 0.0, 15.0, np.pi / 2))  # heading east: 1 m north is to port
    assert np.allclose((x, y), (-1.0, np.sqrt(89.0)))
