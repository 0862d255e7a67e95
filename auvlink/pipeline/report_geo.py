"""The survey map's geography (plotly): GNSS fixes, the closure error, a scale bar, and latitude /
longitude axes (top: longitude, right: latitude, WGS84 deg) when the run is geo-referenced.

Inputs are the run's geo-referencing summary (``georef``: ``georeferenced``, ``closure_m``,
``closure_ne_m``, ``closure_refused``: a closure beyond what navigation can drift, named in the
title) and the track columns (``track_info``: ``fixes`` (n, 3) = time, north, east of the antenna fixes;
``north``, ``east``, ``correction_north``, ``correction_east``, m), both possibly empty;
``to_geodetic`` maps (n, 3) NED m at the site datum to (lat deg, lon deg, height m).
The degree axes are tied to the metric axes (they zoom and pan together): their ticks sit at round
degree values, placed through ``to_geodetic`` (linear about the map centre: mm over a survey).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
import plotly.graph_objects as go

ToGeodetic = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]


def nice_length(length: float) -> float:
    """A round length (1, 2 or 5 x 10^k m) near ``length``."""
    if not length > 0:
        return 1.0
    k = 10.0 ** np.floor(np.log10(length))
    return float(min((1.0, 2.0, 5.0, 10.0), key=lambda m: abs(m * k - length)) * k)


def _degree_ticks(lo_m: float, hi_m: float, centre_m: float, deg0: float, deg_per_m: float
                  ) -> tuple[list[float], list[str]]:
    """Tick positions (m) at round degree values over [lo_m, hi_m] (about 8 of them)."""
    d0, d1 = sorted((deg0 + (lo_m - centre_m) * deg_per_m, deg0 + (hi_m - centre_m) * deg_per_m))
    step = nice_length((d1 - d0) / 8.0)
    values = np.arange(np.ceil(d0 / step), np.floor(d1 / step) + 1) * step
    return ([float(centre_m + (v - deg0) / deg_per_m) for v in values], [f"{v:.5f}" for v in values])


def add_geography(fig: go.Figure, bounds: tuple[float, float, float, float], georef: Mapping[str, Any],
                  track_info: Mapping[str, Any], to_geodetic: ToGeodetic | None) -> str:
    """Draw the fixes, the closure error, the scale bar and (``to_geodetic`` given) the degree axes on
    the map ``fig`` whose data span ``bounds`` = (east min, east max, north min, north max), m;
    returns the map's title."""
    fixes = track_info.get("fixes")
    if fixes is not None and len(fixes):
        f = np.asarray(fixes, dtype=np.float64)
        fig.add_trace(go.Scatter(x=f[:, 2], y=f[:, 1], mode="markers", name="GNSS fixes (antenna)",
                                 marker={"symbol": "cross-thin-open", "size": 7, "color": "#9467bd",
                                         "line": {"width": 1.5, "color": "#9467bd"}},
                                 hovertemplate="GNSS fix<br>north %{y:.1f} m, east %{x:.1f} m<extra></extra>"))
    north, east = track_info.get("north"), track_info.get("east")
    if georef.get("closure_ne_m") is not None and north is not None and east is not None and len(north):
        end = np.array([north[-1], east[-1]], dtype=np.float64)
        before = end - np.array([track_info["correction_north"][-1], track_info["correction_east"][-1]])
        fig.add_annotation(x=end[1], y=end[0], ax=before[1], ay=before[0], xref="x", yref="y", axref="x",
                           ayref="y", showarrow=True, arrowhead=2, arrowwidth=1.5, arrowcolor="#ff7f0e",
                           text="", hovertext=f"closure error {float(georef.get('closure_m', 0.0)):.2f} m "
                           "(dead reckoning -> fixes)")
        fig.add_trace(go.Scatter(x=[None], y=[None], mode="lines", line={"color": "#ff7f0e"},
                                 name=f"closure error {float(georef.get('closure_m', 0.0)):.2f} m"))
    e0, e1, n0, n1 = bounds
    bar = nice_length(max(e1 - e0, n1 - n0) / 5.0)  # the map is at least as wide as it is high
    x0 = e1 + 0.1 * max(e1 - e0, n1 - n0)  # right of the data, at its south end: it covers nothing
    fig.add_shape(type="line", x0=x0, x1=x0 + bar, y0=n0, y1=n0, xref="x", yref="y",
                  line={"color": "#000", "width": 3})
    fig.add_annotation(x=x0 + bar / 2, y=n0, text=f"{bar:g} m", showarrow=False, yshift=10, xref="x", yref="y")
    refused = georef.get("closure_refused")
    note = (f" - GNSS closure refused: {float(refused.get('closure_m') or 0.0):.0f} m, more than navigation can "
            f"drift ({float(refused.get('bound_m') or 0.0):.0f} m): dead-reckoned track kept"
            if isinstance(refused, Mapping) else "")
    if not georef.get("georeferenced") or to_geodetic is None:
        return "Survey map: positions relative to the first navigation sample (no GNSS fix)" + note
    c = np.array([(n0 + n1) / 2, (e0 + e1) / 2, 0.0])
    lat, lon, _ = to_geodetic(np.array([c, c + [100.0, 0.0, 0.0], c + [0.0, 100.0, 0.0]]))
    dlat, dlon = (lat[1] - lat[0]) / 100.0, (lon[2] - lon[0]) / 100.0
    span = max(e1 - e0, n1 - n0, 1.0)  # ticks over a margin: they stay right when the view is zoomed out
    xt, xl = _degree_ticks(e0 - span, e1 + span, float(c[1]), float(lon[0]), float(dlon))
    yt, yl = _degree_ticks(n0 - span, n1 + span, float(c[0]), float(lat[0]), float(dlat))
    fig.add_trace(go.Scatter(x=[None], y=[None], xaxis="x2", yaxis="y2", showlegend=False, hoverinfo="skip"))
    fig.update_layout(
        xaxis2={"title": "longitude [deg E, WGS84]", "overlaying": "x", "side": "top", "matches": "x",
                "tickmode": "array", "tickvals": xt, "ticktext": xl, "showgrid": False},
        yaxis2={"title": "latitude [deg N, WGS84]", "overlaying": "y", "side": "right", "matches": "y",
                "tickmode": "array", "tickvals": yt, "ticktext": yl, "showgrid": False})
    datum = georef.get("datum") or {}
    where = (f" {float(datum['latitude']):.5f} N, {float(datum['longitude']):.5f} E"
             if isinstance(datum, Mapping) and "latitude" in datum and "longitude" in datum else "")
    return f"Survey map: local NED at the datum{where} (GNSS-anchored){note}"
