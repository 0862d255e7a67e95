"""The report's figures (matplotlib, Agg), each returned as PNG bytes."""

from __future__ import annotations

import io
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure
from scipy.spatial.transform import Rotation

from auvlink.pipeline.results import MissionResult
from recon.highlight import HighlightConfig, first_returns, frame_thresholds, onset_rows


def _png(fig: Figure) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()


def survey_map(result: MissionResult) -> bytes:
    """Track (east right, north up), detections with class and score, true objects."""
    fig, ax = plt.subplots(figsize=(8, 7))
    pos = result.track
    if pos.size:
        ax.plot(pos[:, 1], pos[:, 0], "-", color="0.5", lw=1, label="navigation (dead reckoning"
                + (", GNSS-anchored, drift-corrected)" if result.georef.get("georeferenced") else ")"))
    for t in result.setup.truth:
        ax.plot(t.position_ned[1], t.position_ned[0], "s", mfc="none", mec="tab:green", ms=12)
        ax.annotate(t.class_name, (t.position_ned[1], t.position_ned[0]), xytext=(6, -12),
                    textcoords="offset points", color="tab:green", fontsize=8)
    if result.setup.truth:
        ax.plot([], [], "s", mfc="none", mec="tab:green", label="true objects")
    for d in result.detections:
        ax.plot(d.position_ned[1], d.position_ned[0], "o", color="tab:red", ms=6)
        ax.annotate(f"{d.class_name} {d.score:.2f}", (d.position_ned[1], d.position_ned[0]),
                    xytext=(6, 4), textcoords="offset points", color="tab:red", fontsize=8)
    if result.detections:
        ax.plot([], [], "o", color="tab:red", label="detections (class score)")
    hp = result.highlight_points
    if hp is not None and hp.size:
        ax.scatter(hp[:, 1], hp[:, 0], s=1, c="tab:blue", alpha=0.3, label="highlight points")
    from auvlink.pipeline.map_geo import decorate

    title = decorate(ax, result)
    ax.set_xlabel("east [m]")
    ax.set_ylabel("north [m]")
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(1.12, 1.0), fontsize=8)  # beside the map: it hides nothing
    ax.set_title(title, fontsize=10)
    return _png(fig)


def object_views(result: MissionResult, max_objects: int = 12) -> bytes | None:
    dets = result.detections[:max_objects]
    if not dets:
        return None
    cols = min(4, len(dets))
    rows = (len(dets) + cols - 1) // cols
    fig = plt.figure(figsize=(3.2 * cols, 3.0 * rows))
    for k, d in enumerate(dets):
        ax: Any = fig.add_subplot(rows, cols, k + 1, projection="3d")
        p = d.points - np.asarray(d.position_ned)
        ax.scatter(p[:, 1], p[:, 0], -p[:, 2], s=3, c=-p[:, 2], cmap="viridis")
        ax.set_title(f"#{d.id} {d.class_name} ({d.score:.2f}), {d.n_points} pts", fontsize=8)
        ax.set_xlabel("E", fontsize=7)
        ax.set_ylabel("N", fontsize=7)
        ax.set_zlabel("up", fontsize=7)
        ax.tick_params(labelsize=6)
    fig.tight_layout()
    return _png(fig)


def sonar_strip(result: MissionResult) -> bytes | None:
    """Sonar frames near the detections, with the highlight-extension returns drawn."""
    g = result.geometry
    if not result.strip or g is None:
        return None
    frames = sorted(result.strip, key=lambda f: f.t)
    images = np.stack([f.image for f in frames])
    pos = np.concatenate([f.position for f in frames])
    rot = Rotation.concatenate([f.rotation for f in frames])
    alt = np.concatenate([f.altitude for f in frames])
    hc = HighlightConfig()
    onset = g.flat_onset_ranges(pos, rot, alt)
    limits = onset_rows(g, onset, hc.margin_m)
    thr = frame_thresholds(images, int(limits.min(initial=g.n_bins)), hc)
    fi, bi, ri = first_returns(images, limits, thr, hc)
    fig, axes = plt.subplots(1, len(frames), figsize=(2.6 * len(frames), 4.2), squeeze=False)
    r = g.ranges
    for k, ax in enumerate(axes[0]):
        ax.imshow(images[k], aspect="auto", cmap="copper", origin="lower",
                  extent=(-0.5, g.n_beams - 0.5, r[0], r[-1]))
        m = fi == k
        ax.plot(bi[m], r[ri[m]], ".", color="cyan", ms=3)
        ax.plot(np.arange(g.n_beams), np.clip(onset[k], r[0], r[-1]), "--", color="white", lw=0.8)
        ax.set_title(f"t = {frames[k].t:.1f} s", fontsize=8)
        ax.set_xlabel("beam", fontsize=7)
        if k == 0:
            ax.set_ylabel("range [m]", fontsize=7)
        ax.tick_params(labelsize=6)
    fig.suptitle("Sonar frames: highlight-extension returns (cyan), expected seabed onset (dashed)", fontsize=9)
    fig.tight_layout()
    return _png(fig)


def stage_timings(result: MissionResult) -> bytes:
    """Total time per stage, and the per-item latency (p50, p99) of each streaming stage."""
    items = [(k.removesuffix("_s"), v) for k, v in result.timings.items() if k != "total_s"]
    lat = [(k, v) for k, v in result.latency.items() if v.get("p50_ms") is not None]
    fig, axes = plt.subplots(1, 2, figsize=(11, 2.8), squeeze=False)
    ax = axes[0][0]
    ax.barh([k for k, _ in items], [v for _, v in items], color="tab:blue")
    for y, (_, v) in enumerate(items):
        ax.text(v, y, f" {v:.2f} s", va="center", fontsize=8)
    ax.set_xlabel("seconds")
    ax.set_title(f"Time per stage (total {result.timings.get('total_s', 0):.1f} s)", fontsize=9)
    ax = axes[0][1]
    yl = np.arange(len(lat))
    ax.barh(yl - 0.2, [v["p50_ms"] for _, v in lat], height=0.4, color="tab:green", label="p50")
    ax.barh(yl + 0.2, [v["p99_ms"] for _, v in lat], height=0.4, color="tab:orange", label="p99")
    ax.set_yticks(yl, [k for k, _ in lat])
    ax.set_xscale("log")
    ax.set_xlabel("ms per item (frame, poll, object, sample block)")
    ax.set_title("Latency per stage", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return _png(fig)
