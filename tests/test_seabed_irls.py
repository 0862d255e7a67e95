"""recon.seabed_irls gives bit for bit the numbers of the straightforward tiled IRLS fit it replaced."""

from __future__ import annotations

import numpy as np
import pytest

from recon.seabed import SeabedConfig
from recon.seabed_irls import TilePairs, irls_planes

_OFFS = np.array([(i, j) for i in (-1, 0, 1) for j in (-1, 0, 1)], dtype=np.int64)


def _reference_pairs(p: np.ndarray, t: float, overlap: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every point with its 9 neighbouring tiles, filtered (the form recon.seabed had): point, tile, offset/t."""
    cell = np.floor(p[:, :2] / t).astype(np.int64)
    pt_idx = np.repeat(np.arange(p.shape[0]), 9)
    tiles = (cell[:, None, :] + _OFFS[None]).reshape(-1, 2)
    d = p[pt_idx, :2] - (tiles + 0.5) * t
    inside = np.all(np.abs(d) <= t * (0.5 + overlap), axis=1)
    return pt_idx[inside], tiles[inside], d[inside] / t


def _reference_irls(a: np.ndarray, z: np.ndarray, tix: np.ndarray, n_t: int, ridge: float,
                    cfg: SeabedConfig) -> tuple[np.ndarray, np.ndarray]:
    """The IRLS over every point with its 0/1 weight, residuals by einsum (the form recon.seabed had)."""
    w = np.ones(z.size)
    coef = np.zeros((n_t, 3))
    for it in range(max(2, cfg.iterations)):
        ata = np.zeros((n_t, 3, 3))
        atz = np.zeros((n_t, 3))
        for r in range(3):
            atz[:, r] = np.bincount(tix, weights=w * a[:, r] * z, minlength=n_t)
            for c in range(r, 3):
                ata[:, r, c] = ata[:, c, r] = np.bincount(tix, weights=w * a[:, r] * a[:, c], minlength=n_t)
        wsum = np.maximum(ata[:, 0, 0], 1e-12)
        ata[:, 1, 1] += ridge * wsum
        ata[:, 2, 2] += ridge * wsum
        ata[:, 0, 0] += 1e-12
        coef = np.linalg.solve(ata, atz[..., None])[..., 0]
        res = z - np.einsum("ni,ni->n", a, coef[tix])
        if it == 0:
            w = (res >= 0).astype(np.float64)
            continue
        sigma = np.maximum(np.sqrt(np.bincount(tix, weights=w * res**2, minlength=n_t) / wsum), cfg.sigma_floor)
        w = (np.abs(res) <= cfg.clip_sigma * sigma[tix]).astype(np.float64)
    return coef, w


def _points(seed: int, n: int, spread: float) -> np.ndarray:
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-spread, spread, (n, 2)) + np.array([120.0, -35.0])
    z = 20.0 + 0.05 * xy[:, 0] + rng.normal(0.0, 0.03, n)
    z[rng.random(n) < 0.05] -= rng.uniform(0.2, 1.0)  # objects above the seabed
    return np.column_stack([xy, z])


@pytest.mark.parametrize(("seed", "n", "spread"), [(1, 3000, 20.0), (2, 500, 4.0), (3, 20000, 40.0), (4, 50, 300.0)])
def test_pairs_and_planes_bit_identical(seed: int, n: int, spread: float) -> None:
    cfg = SeabedConfig()
    p = _points(seed, n, spread)
    pt_idx, tiles, d = _reference_pairs(p, cfg.tile, cfg.overlap)
    keys, tix = np.unique(tiles, axis=0, return_inverse=True)
    tix = tix.reshape(-1)
    z = p[pt_idx, 2]
    a = np.column_stack([np.ones(z.size), d])
    coef, w = _reference_irls(a, z, tix, keys.shape[0], cfg.ridge, cfg)

    pairs = TilePairs(p, cfg.tile, cfg.overlap)
    got, got_w = irls_planes(pairs.dx, pairs.dy, p[pairs.point, 2], pairs.tix, pairs.counts, cfg.ridge, cfg)
    # the same tiles, each with the same plane and the same points kept
    order = np.lexsort((pairs.ij[:, 1], pairs.ij[:, 0]))
    assert np.array_equal(pairs.ij[order], keys)
    assert got[order].tobytes() == coef.tobytes()
    kept = {(int(k), int(q)) for k, q in zip(tix[w > 0], pt_idx[w > 0], strict=True)}
    rank = np.argsort(order)  # pairs' label -> the reference's tile index
    assert kept == {(int(rank[k]), int(q)) for k, q in zip(pairs.tix[got_w > 0], pairs.point[got_w > 0], strict=True)}


def test_residual_order_is_einsum_order() -> None:
    """The written-out residual adds the three terms in einsum's order (its two-lane inner loop)."""
    rng = np.random.default_rng(5)
    a = np.column_stack([np.ones(100_000), rng.normal(size=(100_000, 2))])
    c = rng.normal(size=(100_000, 3)) * np.array([20.0, 1.0, 1.0])
    ref = np.einsum("ni,ni->n", a, c)
    assert ((c[:, 0] + a[:, 2] * c[:, 2]) + a[:, 1] * c[:, 1]).tobytes() == ref.tobytes()


def test_sparse_tiles_fall_back_to_sorted_keys() -> None:
    """Points spread far apart (a dense grid much larger than the pairs) give the same tiles."""
    p = np.array([[0.0, 0.0, 20.0], [5000.0, -9000.0, 20.0], [1.0, 1.0, 20.1]])
    pairs = TilePairs(p, 6.0, 0.5)
    assert pairs.counts.sum() == pairs.tix.size
    assert np.all(np.diff(pairs.tix) >= 0)
    _, tiles, _ = _reference_pairs(p, 6.0, 0.5)
    assert {tuple(r) for r in pairs.ij.tolist()} == {tuple(r) for r in tiles.tolist()}
