"""Highlight-extension returns: per frame and beam, the first return closer than the seabed onset.

Threshold (adaptive, per frame; robust to speckle and to gain changes, since both statistics shift with the gain
on a log display): median + k * 1.4826 * MAD of the water column, i.e. the rows before the earliest seabed
onset of the frame (a strided grid of about ``stats_samples`` pixels), from a 256-bin histogram; the water
column is mostly background, so this is its level and spread, whatever objects occupy a minority of it. MAD is
floored at one grey level (the display's quantization: a water column at the display's floor has a MAD of 0).
k = 4 robust standard deviations: a Gaussian background exceeds it once in ~30,000 pixels, and the return rule
below needs a second bin. No fixed grey level: recon (:mod:`recon.onset_stage`) raises it per range row to the
background before the onset (:mod:`recon.water_threshold`) and to the row's own level across the fan
(:func:`row_thresholds`).

A return is a bin above the threshold with at least ``min_run`` bins above it (itself included) among the
``run_span_m`` of range that start there: an isolated speckle pixel is ignored, while a surface whose bins fade
under the threshold here and there is not. A surface seen at a shallow angle (the top of a half pipe or a
hemisphere, the seabed) is spread over a range of bins in which speckle (Rayleigh fading) darkens some, and a
renderer that samples the beam's vertical fan with a finite number of rays returns it as a comb of bright bins
3-15 bins apart (r d_elev / tan(elev)); neither is a run of consecutive bins.

Search (vectorized over beams and frames): boolean mask ``image > thr`` limited to rows < the
beam's onset row minus a margin, first True by ``argmax``. With ``skip`` the search reads only
the rows before the latest onset (+ the run length) and searches only the columns (frame, beam)
holding a run above the threshold before their own onset, found with one column max of the
per-pixel run minimum (:func:`first_returns`); without it the whole image is searched (the same
points, more work).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from recon.errors import GeometryError
from recon.exact_stats import median_mad_u8
from recon.frames import check_attitude
from recon.sonar_geometry import GeometryMode, SonarGeometry
from recon.water_threshold import speckle_upper

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
MAD_SCALE = 1.4826
#: water rows a frame threshold needs (8 rows x 24 sampled beams: a median and MAD from ~200 pixels); fewer: whole image
MIN_STAT_ROWS = 8


@dataclass(frozen=True)
class HighlightConfig:
    k: float = 4.0  # robust standard deviations above the water's median (module docstring)
    min_run: int = 2  # bins above the threshold ...
    run_span_m: float = 0.25  # ... among this much range from the return's own bin (>= min_run bins)
    margin_m: float = 0.1  # search only rows closer than onset - margin
    stats_samples: int = 1024  # pixels per frame behind the robust statistics (strided grid)
    skip: bool = True
    geometry: GeometryMode = "exact"
    dtype: Literal["float64", "float32"] = "float64"


@dataclass(frozen=True, eq=False)
class HighlightPoints:
    """Points (N, 3) in W with the batch frame index, beam (column) and row of each."""

    points: NDArray[np.floating]
    frame: I64
    beam: I64
    row: I64

    def __len__(self) -> int:
        return int(self.frame.shape[0])


def span_bins(min_run: int, span_m: float, bin_m: float) -> int:
    """``span_m`` of range in bins of ``bin_m`` m, at least ``min_run``: the span of the return rule (the module
    doc), shared with the classifier's synthesis
    (:attr:`classify.training.synthesis_settings.SynthesisSettings.span_bins`)."""
    run = max(1, min_run)
    return max(run, round(span_m / bin_m)) if bin_m > 0 else run


def run_span_bins(cfg: HighlightConfig, bin_m: float) -> int:
    """The span of :attr:`HighlightConfig.run_span_m` in bins of ``bin_m`` m (at least ``min_run``)."""
    return span_bins(cfg.min_run, cfg.run_span_m, bin_m)


def _starts(above: NDArray[np.bool_], n_valid: int, run: int, span: int) -> NDArray[np.bool_]:
    """Where a return starts, (F, n_valid, B) of ``above`` (F, R, B): the bin is above the threshold and at
    least ``run`` of the ``span`` bins from it (those inside the image) are."""
    first = above[:, :n_valid]
    if run <= 1:
        return first
    if run == 2:  # any of the next span - 1 bins: a sliding OR by doubling (log2(span) passes, not span)
        w = span - 1
        nxt = np.zeros((above.shape[0], n_valid + w - 1, above.shape[2]), bool)
        tail = above[:, 1 : n_valid + w]
        nxt[:, : tail.shape[1]] = tail
        k = 1
        while 2 * k <= w:
            nxt = nxt[:, :-k] | nxt[:, k:]
            k *= 2
        return first & (nxt[:, :n_valid] | nxt[:, w - k : w - k + n_valid])
    count = first.astype(np.uint8)
    for k in range(1, span):
        m = min(n_valid, above.shape[1] - k)
        if m <= 0:
            break
        count[:, :m] += above[:, k : k + m]
    return first & (count >= run)


def _hist_median(hist: NDArray[np.int64]) -> I64:
    """Per-row median value of (F, 256) histograms (lower median)."""
    c = np.cumsum(hist, axis=1)
    half = (c[:, -1:] + 1) // 2
    return np.asarray(np.argmax(c >= half, axis=1), dtype=np.int64)


def frame_thresholds(images: NDArray[np.uint8], stat_rows: int, cfg: HighlightConfig) -> F64:
    """Per-frame thresholds of a (F, bins, beams) uint8 stack (see the module docstring)."""
    f, n_bins, n_beams = images.shape
    rows = n_bins if stat_rows < MIN_STAT_ROWS else stat_rows
    cs = 4 if n_beams >= 32 else 1
    rs = max(1, int(rows * (n_beams // cs) / max(1, cfg.stats_samples)))
    sample = images[:, :rows:rs, ::cs]
    offs = (np.arange(f, dtype=np.int64) * 256)[:, None]
    flat = sample + offs[:, :, None]  # frame f's values in [256 f, 256 f + 256): one bincount for all
    hist = np.bincount(flat.ravel(), minlength=256 * f).reshape(f, 256)
    med = _hist_median(hist)
    dist = np.abs(np.arange(256)[None, :] - med[:, None]) + offs
    dhist = np.bincount(dist.ravel(), weights=hist.ravel(), minlength=256 * f).reshape(f, 256)
    mad = np.maximum(_hist_median(dhist.astype(np.int64)), 1).astype(np.float64)
    return np.asarray(med + cfg.k * MAD_SCALE * mad, dtype=np.float64)


def row_background(images: NDArray[np.uint8], n_rows: int) -> tuple[F64, F64]:
    """Median and MAD (MAD floored at one grey level) over the beams of each of the first ``n_rows`` rows of a stack
    (F, bins, beams): what the fan sees at each range (objects fill a minority of the beams); (F, n_rows) each."""
    med, mad = median_mad_u8(np.asarray(images[:, :n_rows], dtype=np.uint8))
    return med, np.maximum(mad, 1.0)


def row_thresholds(images: NDArray[np.uint8], thr: F64, n_rows: int | None = None) -> F64:
    """(F, bins) thresholds: per frame and range row, at least ``thr`` (per frame (F,) or row (F, bins)) and, in
    the first ``n_rows`` rows (default all), the level that speckle of the row's median and MAD over the beams
    (:func:`row_background`) exceeds once in 1 / PFA pixels (:func:`recon.water_threshold.speckle_upper`): a return
    stands out of what the fan sees at its range, whatever gain, TVG and vertical pattern made the seabed's ramp,
    an interference band or a sidelobe arc that spans the fan."""
    f, n_bins, _ = images.shape
    n = n_bins if n_rows is None else max(0, min(n_bins, int(n_rows)))
    floor = np.asarray(thr, np.float64)
    return thresholds_over(np.broadcast_to(floor if floor.ndim == 2 else floor[:, None], (f, n_bins)),
                           *row_background(images, n))


def thresholds_over(thr: F64, med: F64, mad: F64) -> F64:
    """:func:`row_thresholds` over ``thr`` (F, bins) from the rows' background (``med``, ``mad`` (F, n) of
    :func:`row_background`)."""
    out = np.array(thr, dtype=np.float64)
    n = med.shape[1]
    out[:, :n] = np.maximum(out[:, :n], speckle_upper(med, mad))
    return out


def interfered_rows(med: F64, background: F64, limits: I64) -> NDArray[np.bool_]:
    """(F, n) rows bright across most of the fan before every beam's onset: the row's median over the beams
    (``med`` of :func:`row_background`) above the ``background`` threshold (F, bins) of the water there (an
    interference band, a fan-wide arc); ``limits`` (F, beams) the onset rows."""
    n = med.shape[1]
    before = np.arange(n)[None, :] < limits.min(axis=1, initial=n)[:, None]
    return np.asarray(before & (med > background[:, :n]), dtype=np.bool_)


def onset_rows(geometry: SonarGeometry, onset: F64, margin_m: float) -> I64:
    """Row limits (exclusive) per frame and beam: rows whose range is < onset - margin."""
    lim = np.ceil(geometry.range_to_row(onset - margin_m))
    lim = np.where(np.isfinite(lim), lim, geometry.n_bins)
    return np.clip(lim, 0, geometry.n_bins).astype(np.int64)


def _column_max(x: NDArray[np.uint8]) -> NDArray[np.uint8]:
    """Max over axis 1 of (F, R, B) by halving R: each step one ufunc call over long contiguous blocks
    (``x.max(axis=1)`` loops over rows of only B = 96 bytes, ~8x slower on 512 x 96 frames)."""
    while x.shape[1] > 1:
        h = x.shape[1] // 2
        y = np.maximum(x[:, :h], x[:, h : 2 * h])
        if x.shape[1] % 2:
            np.maximum(y[:, :1], x[:, 2 * h :], out=y[:, :1])
        x = y
    return x[:, 0]


def first_returns(images: NDArray[np.uint8], limits: I64, thr: F64, cfg: HighlightConfig, span: int | None = None
                  ) -> tuple[I64, I64, I64]:
    """(frame, beam, row) of the first return (see the module doc) in rows < ``limits`` (F, beams); ``thr`` per
    frame (F,) or per frame and row (F, bins) (:func:`row_thresholds`).

    ``span``: the bins of ``cfg.run_span_m`` (:func:`run_span_bins`); None: ``cfg.min_run`` (consecutive bins).
    With ``cfg.skip`` only the rows before the latest onset (+ the span) are read, and only the columns (frame,
    beam) that hold a return before their own onset are searched: the returns of the frame (rows at or past the
    beam's onset cleared), one column max, then ``argmax`` on the live columns alone (on seabed-only frames
    with speckle, almost none). Without it the whole image is searched; the same points either way.
    """
    f, n_bins, _ = images.shape
    run = max(1, cfg.min_run)
    span = run if span is None else max(run, int(span))
    n_valid = n_bins - run + 1  # rows where a return may start (``run`` bins must fit in the image)
    thr_u = np.clip(np.floor(thr), 0, 255).astype(np.uint8)  # x > thr <=> x > floor(thr) for integers
    thr_u = thr_u[:, :, None] if thr_u.ndim == 2 else thr_u[:, None, None]  # per row (F, bins) or per frame (F,)
    empty: tuple[I64, I64, I64] = (np.zeros(0, np.int64),) * 3
    if f == 0 or n_valid <= 0:
        return empty
    if cfg.skip:
        n_valid = min(int(limits.max(initial=0)), n_valid)
        if n_valid <= 0:
            return empty
        rows = min(n_bins, n_valid + span - 1)
        above = images[:, :rows] > thr_u[:, :rows]
        start = _starts(above, n_valid, run, span)  # ours (a view of ``above`` at most): cleared below
        lo = int(limits.min(initial=n_valid))
        if lo < n_valid:  # rows at or past a beam's own onset row cannot start a return
            band = start[:, lo:]
            band[np.arange(lo, n_valid)[None, :, None] >= limits[:, None, :]] = False
        lf, lb = np.nonzero(_column_max(start.view(np.uint8)))
        first = np.argmax(start[lf, :, lb], axis=1)  # (live columns, rows)
        return lf.astype(np.int64), lb.astype(np.int64), first.astype(np.int64)
    mask = _starts(images > thr_u, n_valid, run, span)
    rows = np.arange(n_valid)
    mask = mask & (rows[None, :, None] < limits[:, None, :])
    first = np.argmax(mask, axis=1)  # (F, beams)
    hit = np.take_along_axis(mask, first[:, None, :], axis=1)[:, 0, :]
    fi, bi = np.nonzero(hit)
    return fi.astype(np.int64), bi.astype(np.int64), first[fi, bi].astype(np.int64)


def returns_between(images: NDArray[np.uint8], lo: I64, hi: I64, thr: F64, min_run: int = 2
                    ) -> tuple[I64, I64, I64]:
    """(frame, beam, row) of the first run above ``thr`` with lo <= row < hi (both (F, beams)).

    Used for the seabed returns at the onset (lo = onset row - margin, hi = lo + a band); ``thr`` per frame (F,)
    or per frame and row (F, bins).
    """
    n_bins = images.shape[1]
    a, b = int(lo.min(initial=n_bins)), int(min(n_bins, hi.max(initial=0) + max(1, min_run) - 1))
    if b - a < max(1, min_run):
        return (np.zeros(0, np.int64),) * 3
    thr_u = np.clip(np.floor(thr), 0, 255).astype(np.uint8)
    above = images[:, a:b] > (thr_u[:, a:b, None] if thr_u.ndim == 2 else thr_u[:, None, None])
    n_valid = b - a - max(1, min_run) + 1
    mask = above[:, :n_valid]
    for k in range(1, max(1, min_run)):
        mask = mask & above[:, k : k + n_valid]
    rows = np.arange(a, a + n_valid)[None, :, None]
    mask = mask & (rows >= lo[:, None, :]) & (rows < hi[:, None, :])
    first = np.argmax(mask, axis=1)
    hit = np.take_along_axis(mask, first[:, None, :], axis=1)[:, 0, :]
    fi, bi = np.nonzero(hit)
    return fi.astype(np.int64), bi.astype(np.int64), (first[fi, bi] + a).astype(np.int64)


def project(geometry: SonarGeometry, frame: I64, beam: I64, row: I64, positions: F64, rotations: Rotation,
            mode: GeometryMode = "exact", dtype: str = "float64", phi: F64 | None = None
            ) -> NDArray[np.floating]:
    """World points of returns (frame, beam, row) placed on the highlight ray (or at ``phi``)."""
    dt = np.dtype(dtype)
    r = geometry.ranges[row].astype(dt)
    if phi is None:
        dirs = geometry.highlight_directions(mode).astype(dt)[beam]
    else:
        dirs = geometry.directions_body(phi, geometry.azimuths[beam]).astype(dt)
    p_b = r[:, None] * dirs + geometry.mounting.lever.astype(dt)
    mats = rotations.as_matrix().reshape(-1, 3, 3).astype(dt)[frame]
    # the offsets from the vehicle in ``dtype``, the world position in float64: float32 world coordinates
    # lose mm far from the origin (6 cm at 1e6 m)
    pos = np.asarray(positions, dtype=np.float64).reshape(-1, 3)[frame]
    return np.einsum("nij,nj->ni", mats, p_b) + pos


def extract(images: NDArray[np.uint8], positions: F64, rotations: Rotation, onset: F64,
            geometry: SonarGeometry, cfg: HighlightConfig | None = None) -> HighlightPoints:
    """Highlight-extension points of a stack of frames (F, n_bins, n_beams) uint8.

    ``positions`` (F, 3) / ``rotations`` (F) are the vehicle poses at the frame times, ``onset``
    (F, n_beams) the expected seabed onset ranges (:meth:`SonarGeometry.onset_ranges`).
    """
    c = cfg or HighlightConfig()
    imgs = np.asarray(images)
    if imgs.ndim == 2:
        imgs = imgs[None]
    if imgs.dtype != np.uint8 or imgs.shape[1:] != (geometry.n_bins, geometry.n_beams):
        raise GeometryError(f"expected uint8 frames of {(geometry.n_bins, geometry.n_beams)}, "
                            f"got {imgs.dtype} {imgs.shape[1:]}")
    check_attitude(rotations)
    limits = onset_rows(geometry, np.atleast_2d(onset), c.margin_m)
    stat_rows = int(limits.min(initial=geometry.n_bins))
    thr = frame_thresholds(imgs, stat_rows, c)
    fi, bi, ri = first_returns(imgs, limits, thr, c, run_span_bins(c, geometry.bin_size))
    pts = project(geometry, fi, bi, ri, positions, rotations, c.geometry, c.dtype)
    return HighlightPoints(pts, fi, bi, ri)
