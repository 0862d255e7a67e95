"""Seabed removal by height above a locally fitted seabed: flat and 5-degree sloped seabeds."""

from __future__ import annotations

import numpy as np
import pytest

from recon.errors import ReconError
from recon.seabed import SeabedConfig, SeabedModel, object_mask

D = np.deg2rad


def _seabed(xy: np.ndarray, slope_deg: float, azimuth_deg: float) -> np.ndarray:
    a = D(azimuth_deg)
    return 20.0 + np.tan(D(slope_deg)) * (xy[:, 0] * np.cos(a) + xy[:, 1] * np.sin(a))


def _survey(rng: np.random.Generator, slope: float, az: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    # DVL seabed points under three survey lines + sonar seabed returns across a 4 m swath
    lines = [np.column_stack([np.arange(0, 80, 0.2), np.full(400, y)]) for y in (0.0, 3.5, 7.0)]
    dvl = np.concatenate(lines)
    swath = np.column_stack([rng.uniform(0, 80, 6000), rng.uniform(-2, 9, 6000)])
    sb_xy = np.concatenate([dvl, swath])
    seabed = np.column_stack([sb_xy, _seabed(sb_xy, slope, az) + rng.normal(0, 0.02, len(sb_xy))])
    # objects: points of boxes 0.3..1.0 m high, plus returns from the seabed right next to them
    objs = []
    for cx, cy, hgt in ((12, 1, 0.6), (30, 5, 1.0), (47, 2, 0.3), (66, 6, 0.8)):
        n = 300
        xy = np.column_stack([rng.uniform(cx - 0.6, cx + 0.6, n), rng.uniform(cy - 0.4, cy + 0.4, n)])
        h = rng.uniform(0.25, hgt, n)
        objs.append(np.column_stack([xy, _seabed(xy, slope, az) - h]))
    obj = np.concatenate(objs)
    near_xy = np.column_stack([rng.uniform(0, 80, 3000), rng.uniform(-1, 8, 3000)])
    near = np.column_stack([near_xy, _seabed(near_xy, slope, az) + rng.normal(0, 0.02, 3000)])
    return seabed, obj, near


@pytest.mark.parametrize(("slope", "az"), [(0.0, 0.0), (5.0, 0.0), (5.0, 90.0), (5.0, 37.0)])
def test_removal_keeps_objects_drops_seabed(slope: float, az: float) -> None:
    rng = np.random.default_rng(11)
    seabed, obj, near = _survey(rng, slope, az)
    # the object points are among the fitted points too (they are part of the cloud): robust to them
    model = SeabedModel.fit(np.concatenate([seabed, obj]), SeabedConfig())
    keep_obj = object_mask(obj, model)
    keep_near = object_mask(near, model)
    assert keep_obj.mean() > 0.97
    assert keep_near.mean() < 0.01
    # the fitted seabed follows the slope within a few centimetres
    q = np.column_stack([rng.uniform(2, 78, 500), rng.uniform(0, 7, 500)])
    assert np.abs(model.depth_at(q) - _seabed(q, slope, az)).max() < 0.05


def test_global_threshold_would_fail_on_slope() -> None:
    rng = np.random.default_rng(12)
    _, _, near = _survey(rng, 5.0, 0.0)
    z_cut = np.median(near[:, 2]) - 0.15  # one global "above the seabed" depth
    assert (near[:, 2] < z_cut).mean() > 0.3  # a third of the seabed would pass as objects


def test_single_line_and_sparse_tiles() -> None:
    xy = np.column_stack([np.arange(0, 50, 0.25), np.zeros(200)])
    pts = np.column_stack([xy, 20.0 + 0.05 * xy[:, 0]])
    model = SeabedModel.fit(pts)
    q = np.array([[10.0, 0.0], [10.0, 2.0], [10.0, -3.0], [200.0, 0.0]])
    z = model.depth_at(q)
    assert np.allclose(z[:3], 20.5, atol=0.01)  # no invented cross slope
    assert np.isfinite(z[3])  # far away: the nearest fitted tile
    n = model.plane_at(q[:1])[1][0]
    assert n[2] < 0 and np.isclose(n[0] / -n[2], 0.05, atol=1e-3)
    with pytest.raises(ReconError):
        SeabedModel.fit(pts[:3])


def test_far_from_origin() -> None:
    rng = np.random.default_rng(13)
    seabed, obj, near = _survey(rng, 5.0, 20.0)
    off = np.array([8e5, -6e5, 0.0])
    model = SeabedModel.fit(np.concatenate([seabed, obj]) + off)
    assert object_mask(obj + off, model).mean() > 0.97
    assert object_mask(near + off, model).mean() < 0.01


def test_a_too_wide_cluster_keeps_an_object_core_and_a_crest_field_is_dropped() -> None:
    """recon.poll_seabed.on_seabed: a box (0.6 m high) whose cluster reached out over 5 m of low seabed points
    keeps the box; a field of crests 6 m wide, all about as high, is still no object."""
    from recon.cluster import make_object
    from recon.poll_seabed import on_seabed

    rng = np.random.default_rng(3)
    xy = rng.uniform(-20, 20, (4000, 2))
    model = SeabedModel.fit(np.column_stack([xy, np.full(len(xy), 30.0)]), SeabedConfig())
    box = np.column_stack([rng.uniform(-0.5, 0.5, (400, 2)), 30.0 - rng.uniform(0.3, 0.6, 400)])
    skirt = np.column_stack([rng.uniform(-5.0, 0.0, 60), rng.uniform(-0.3, 0.3, 60), 30.0 - rng.uniform(0.2, 0.25, 60)])
    pts = np.concatenate([box, skirt])
    field = np.column_stack([rng.uniform(-3, 3, (300, 2)), 30.0 - rng.uniform(0.2, 0.3, 300)])
    objs = [make_object(0, pts, np.zeros(len(pts))), make_object(1, field, np.zeros(len(field)))]
    rejected: dict[str, int] = {}
    out = on_seabed(objs, model, rejected)  # the envelope: clusters up to 4.5 m, tops 0.15 m high
    assert [o.id for o in out] == [0] and rejected == {"too_wide": 1}
    assert out[0].extent[0] < 1.1 and out[0].n_points >= 390  # the box, without the skirt
    assert out[0].seabed_depth == pytest.approx(30.0, abs=0.01)
