"""Training-time augmentation of batches of clouds ``(B, N, 3)`` (NED: z down), seeded.

* random yaw about the down axis (the object's heading and the pass direction are unknown),
* jitter: clipped Gaussian noise per point,
* point dropout: a random fraction of each cloud (up to ``dropout_max``) replaced by copies of
  its first point, which leaves a max-pooled network's input set unchanged in size,
* random scale (isotropic, small): the unit-sphere scaling of a reconstructed cloud is itself noisy,
* plane cut (first, with probability ``cut_prob``): the points beyond a random vertical plane, a
  fraction up to ``cut_max`` of the cloud, are replaced by copies of kept points (a pass that saw
  only part of the object's footprint), and the cloud is scaled back into the unit sphere,
* seabed error (``z_shift = (lo, hi)``, seabed-referenced clouds only): the seabed under a cloud taken
  deeper by one uniform draw in ``[lo, hi]`` (normalized units; the object looks that much taller), as
  recon's fitted seabed is uncertain and, its seabed returns lagging like the object's, biased deep
  (0-0.12 m on simulated passes).
* seabed slope (``tilt_deg``, seabed-referenced clouds only): each cloud turned about a random horizontal axis
  through its centre on the seabed by up to ``tilt_deg``: an object rests on a sloped seabed tilted with it,
  and recon gives the classifier one seabed depth under it (the planes' median), so the cloud leans;
* attached clutter (``attach_prob``, with a pool of clutter clouds): an object cloud gets a fraction (drawn from
  ``attach_fraction``) of its points replaced by those of a clutter cloud placed against its side (a random
  direction, its centre ``attach_gap`` times the object's horizontal radius out), then re-centred: on a rough
  seabed recon's cluster of an object often holds a crest next to it.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

F32 = npt.NDArray[np.float32]


@dataclass(frozen=True)
class AugmentConfig:
    yaw: bool = True
    jitter_sigma: float = 0.01
    jitter_clip: float = 0.03
    dropout_max: float = 0.5
    scale: tuple[float, float] = (0.9, 1.1)
    cut_prob: float = 0.0
    cut_max: float = 0.4
    z_shift: tuple[float, float] = (0.0, 0.0)
    tilt_deg: float = 0.0
    attach_prob: float = 0.0
    attach_fraction: tuple[float, float] = (0.05, 0.3)
    attach_gap: tuple[float, float] = (0.8, 1.5)
    #: False: clouds made by recon's own seabed removal (``CloudSet.measured``) get no ``z_shift``, ``tilt_deg`` or
    #: attached clutter: their seabed error is the one recon made
    seabed_error_on_measured: bool = True

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> AugmentConfig:
        kw: dict[str, Any] = {k: (tuple(d[k]) if isinstance(d[k], list) else d[k])
                              for k in cls.__dataclass_fields__ if k in d}
        return cls(**kw)


def random_yaw(points: F32, rng: np.random.Generator) -> F32:
    """Rotate each cloud by a uniform random angle about the z (down) axis."""
    a = rng.uniform(0.0, 2 * np.pi, size=len(points))
    c, s = np.cos(a), np.sin(a)
    rot = np.zeros((len(points), 3, 3), dtype=np.float32)
    rot[:, 0, 0], rot[:, 0, 1], rot[:, 1, 0], rot[:, 1, 1], rot[:, 2, 2] = c, -s, s, c, 1.0
    return np.einsum("bnj,bij->bni", points, rot).astype(np.float32)


def jitter(points: F32, rng: np.random.Generator, sigma: float = 0.01, clip: float = 0.03) -> F32:
    """Add Gaussian noise of ``sigma`` clipped to ``+-clip`` to every coordinate."""
    noise = np.clip(sigma * rng.standard_normal(points.shape), -clip, clip)
    return (points + noise).astype(np.float32)


def point_dropout(points: F32, rng: np.random.Generator, max_ratio: float = 0.5) -> F32:
    """Replace a random fraction in ``[0, max_ratio)`` of each cloud's points by its first point."""
    out = points.copy()
    b, n, _ = points.shape
    ratio = rng.uniform(0.0, max_ratio, size=(b, 1))
    drop = rng.random((b, n)) < ratio
    drop[:, 0] = False
    rows, cols = np.nonzero(drop)
    out[rows, cols] = points[rows, 0]
    return out


def random_scale(points: F32, rng: np.random.Generator, low: float = 0.9, high: float = 1.1) -> F32:
    return (points * rng.uniform(low, high, size=(len(points), 1, 1))).astype(np.float32)


def normalize_batch(points: F32, fixed_scale: bool = False, keep_z: bool = False) -> F32:
    """Each cloud of ``(B, N, 3)`` centred on its mean and divided by its largest norm (only centred
    with ``fixed_scale``: clouds already in metres / a fixed scale, see ``SynthesisSettings.scale_m``;
    only centred horizontally with ``keep_z`` as well: z is the height above the seabed)."""
    centre = points.mean(axis=1, keepdims=True)
    if fixed_scale and keep_z:
        centre[..., 2] = 0.0
    p = points - centre
    if fixed_scale:
        return p.astype(np.float32)
    r = np.linalg.norm(p, axis=2).max(axis=1)
    return (p / np.where(r > 0, r, 1.0)[:, None, None]).astype(np.float32)


def plane_cut(points: F32, rng: np.random.Generator, prob: float, max_ratio: float,
              fixed_scale: bool = False, keep_z: bool = False) -> F32:
    """With probability ``prob`` per cloud, drop the points beyond a random vertical plane (a fraction
    uniform in ``[0, max_ratio)``), fill with copies of kept points, rescale to the unit sphere."""
    b, n, _ = points.shape
    a = rng.uniform(0.0, 2 * np.pi, size=b)
    d = np.stack([np.cos(a), np.sin(a), np.zeros(b)], axis=1)
    order = np.argsort(np.einsum("bnk,bk->bn", points, d), axis=1)  # ascending: kept first
    frac = rng.uniform(0.0, max_ratio, size=b) * (rng.random(b) < prob)
    n_keep = np.maximum(1, np.ceil(n * (1.0 - frac)).astype(np.int64))
    pick = np.floor(rng.random((b, n)) * n_keep[:, None]).astype(np.int64)  # random kept rank
    ranks = np.where(np.arange(n)[None, :] < n_keep[:, None], np.arange(n)[None, :], pick)
    out = np.take_along_axis(points, np.take_along_axis(order, ranks, axis=1)[:, :, None], axis=1)
    cut = frac > 0
    out[cut] = normalize_batch(out[cut], fixed_scale, keep_z)
    out[~cut] = points[~cut]
    return out


def random_tilt(points: F32, rng: np.random.Generator, max_deg: float) -> F32:
    """Turn each cloud about a random horizontal axis through its horizontal centre at ``z = 0`` (the seabed)
    by an angle uniform in ``[0, max_deg]`` degrees."""
    b = len(points)
    a = rng.uniform(0.0, 2 * np.pi, size=b)
    axis = np.stack([np.cos(a), np.sin(a), np.zeros(b)], axis=1) * np.radians(rng.uniform(0.0, max_deg, b))[:, None]
    rot = Rotation.from_rotvec(axis).as_matrix().astype(np.float32)
    centre = points.mean(axis=1, keepdims=True)
    centre[..., 2] = 0.0
    return (np.einsum("bnj,bij->bni", points - centre, rot) + centre).astype(np.float32)


def attach_clutter(points: F32, rng: np.random.Generator, pool: F32, prob: float, fraction: tuple[float, float],
                   gap: tuple[float, float]) -> F32:
    """With probability ``prob`` per cloud, replace a fraction of its points by points of a random cloud of
    ``pool`` placed against its side (see the module docstring); clouds centred horizontally, z kept."""
    out = points.copy()
    b, n, _ = points.shape
    sel = np.flatnonzero(rng.random(b) < prob)
    for i in sel:
        c = pool[int(rng.integers(len(pool)))]
        centre = out[i, :, :2].mean(axis=0)
        radius = float(np.linalg.norm(out[i, :, :2] - centre, axis=1).max())
        a = rng.uniform(0.0, 2 * np.pi)
        at = centre + np.array([np.cos(a), np.sin(a)]) * radius * rng.uniform(*gap)
        m = round(n * float(rng.uniform(*fraction)))
        rows = rng.choice(n, m, replace=False)
        piece = c[rng.integers(0, len(c), m)].copy()
        piece[:, :2] += (at - c[:, :2].mean(axis=0)).astype(np.float32)
        out[i, rows] = piece
        out[i, :, :2] -= out[i, :, :2].mean(axis=0)
    return out


def augment_batch(points: F32, rng: np.random.Generator, cfg: AugmentConfig, fixed_scale: bool = False,
                  keep_z: bool = False, pool: F32 | None = None, attach: npt.NDArray[np.bool_] | None = None,
                  measured: npt.NDArray[np.bool_] | None = None) -> F32:
    """All augmentations of ``cfg`` applied to a batch (a new array); ``keep_z``: z is the height above
    the seabed (never re-centred; shifted by ``z_shift``). ``pool``: clutter clouds that may be attached to the
    clouds where ``attach`` is True (``attach_prob``). ``measured``: the clouds made by recon's own seabed removal
    (no seabed-error augmentation unless ``seabed_error_on_measured``)."""
    out = np.asarray(points, dtype=np.float32)
    spare = np.zeros(len(out), bool) if measured is None or cfg.seabed_error_on_measured else np.asarray(measured)
    if attach is not None:
        attach = attach & ~spare
    if cfg.attach_prob > 0 and pool is not None and len(pool) and attach is not None and attach.any():
        out = out.copy()
        out[attach] = attach_clutter(out[attach], rng, pool, cfg.attach_prob, cfg.attach_fraction, cfg.attach_gap)
    if cfg.cut_prob > 0:
        out = plane_cut(out, rng, cfg.cut_prob, cfg.cut_max, fixed_scale, keep_z)
    if keep_z and cfg.z_shift[1] > cfg.z_shift[0]:
        out = out.copy()
        shift = rng.uniform(*cfg.z_shift, size=(len(out), 1)).astype(np.float32)
        out[..., 2] -= np.where(spare[:, None], np.float32(0.0), shift)
    if keep_z and cfg.tilt_deg > 0:
        tilted = random_tilt(out, rng, cfg.tilt_deg)
        out = np.where(spare[:, None, None], out, tilted)
    if cfg.yaw:
        out = random_yaw(out, rng)
    if cfg.scale[0] != 1.0 or cfg.scale[1] != 1.0:
        out = random_scale(out, rng, *cfg.scale)
    if cfg.jitter_sigma > 0:
        out = jitter(out, rng, cfg.jitter_sigma, cfg.jitter_clip)
    if cfg.dropout_max > 0:
        out = point_dropout(out, rng, cfg.dropout_max)
    return out
