"""The survey map's geography: latitude / longitude on the top and right axes, a scale bar, the GNSS
fixes and the closure error (the drift found when the vehicle surfaced)."""

from __future__ import annotations

from typing import Any

import numpy as np

from auvlink.geodesy import Datum
from auvlink.pipeline.results import MissionResult


def _nice(length: float) -> float:
    """A round length (1, 2 or 5 x 10^k m) near ``length``."""
    if length <= 0:
        return 1.0
    k = 10.0 ** np.floor(np.log10(length))
    return float(min((1.0, 2.0, 5.0, 10.0), key=lambda m: abs(m * k - length)) * k)


def _degree_axes(ax: Any, datum: Datum) -> None:
    """Top axis: longitude, right axis: latitude (deg), linear at the map centre (exact to mm over a survey)."""
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    c = np.array([(y0 + y1) / 2, (x0 + x1) / 2, 0.0])
    lat, lon, _ = datum.to_geodetic(np.array([c, c + [100.0, 0, 0], c + [0, 100.0, 0]]))
    dlat, dlon = (lat[1] - lat[0]) / 100.0, (lon[2] - lon[0]) / 100.0
    top = ax.secondary_xaxis("top", functions=(lambda e: lon[0] + (e - c[1]) * dlon,
                                               lambda g: c[1] + (g - lon[0]) / dlon))
    right = ax.secondary_yaxis("right", functions=(lambda n: lat[0] + (n - c[0]) * dlat,
                                                   lambda g: c[0] + (g - lat[0]) / dlat))
    top.set_xlabel("longitude [deg E, WGS84]", fontsize=8)
    right.set_ylabel("latitude [deg N, WGS84]", fontsize=8)
    from matplotlib.ticker import FormatStrFormatter, MaxNLocator

    for a, axis in ((top, top.xaxis), (right, right.yaxis)):
        a.tick_params(labelsize=7)
        axis.set_major_locator(MaxNLocator(4))
        axis.set_major_formatter(FormatStrFormatter("%.5f"))


def _square_up(ax: Any) -> None:
    """Widen the shorter side to at least half the longer one (a single survey line is otherwise a sliver)."""
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    w, h = x1 - x0, y1 - y0
    if w < 0.5 * h:
        c = (x0 + x1) / 2
        ax.set_xlim(c - 0.25 * h, c + 0.25 * h)
    elif h < 0.5 * w:
        c = (y0 + y1) / 2
        ax.set_ylim(c - 0.25 * w, c + 0.25 * w)


def decorate(ax: Any, result: MissionResult) -> str:
    """Draw the fixes, the closure error, the scale bar and the degree axes; return the map's title."""
    from matplotlib.font_manager import FontProperties
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    geo = result.georef
    track = result.track_info
    fixes = track.get("fixes")
    if fixes is not None and len(fixes):
        ax.plot(fixes[:, 2], fixes[:, 1], "+", color="tab:purple", ms=5, label="GNSS fixes (antenna)")
    closure = geo.get("closure_ne_m")
    if closure is not None and track.get("north") is not None and len(track["north"]):
        end = np.array([track["north"][-1], track["east"][-1]])
        before = end - np.array([track["correction_north"][-1], track["correction_east"][-1]])
        ax.annotate("", xy=(end[1], end[0]), xytext=(before[1], before[0]),
                    arrowprops={"arrowstyle": "->", "color": "tab:orange", "lw": 1.5})
        ax.plot([], [], "-", color="tab:orange", label=f"closure error {geo.get('closure_m', 0.0):.2f} m "
                "(dead reckoning -> fixes)")
    _square_up(ax)
    x0, x1 = ax.get_xlim()
    bar = _nice((x1 - x0) / 5.0)
    ax.add_artist(AnchoredSizeBar(ax.transData, bar, f"{bar:g} m", "lower right", pad=0.4, frameon=True,
                                  size_vertical=(x1 - x0) / 200.0, fontproperties=FontProperties(size=8)))
    datum = Datum.from_dict(geo.get("datum"))
    if geo.get("georeferenced") and datum is not None:
        _degree_axes(ax, datum)
        return (f"Survey map: local NED at the datum {datum.latitude:.5f} N, {datum.longitude:.5f} E "
                "(GNSS-anchored)")
    return "Survey map: positions relative to the first navigation sample (no GNSS fix)"
