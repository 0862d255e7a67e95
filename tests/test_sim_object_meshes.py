"""Object catalog: mesh sizes, closed components, frames, placement on the seabed."""

from __future__ import annotations

import numpy as np
import pytest

from auvlink.sim.mesh_builders import BUILDERS
from auvlink.sim.object_meshes import CLASSES, bounding_sphere, class_material, mesh_for, placed_mesh
from auvlink.sim.scene import SceneObject, Seabed
from auvlink.sim.seabed import SeabedSurface

# length (x) x width (y) x height (m)
SIZES = {
    "sphere": (1.0, 1.0, 1.0),
    "hemisphere": (1.0, 1.0, 0.5),
    "pipe": (3.0, 0.6, 0.6),
    "half_pipe": (3.0, 0.6, 0.3),
    "box": (1.2, 0.8, 0.6),
    "reef_a": (1.6, 1.6, 1.5),
    "reef_b": (2.0, 1.5, 1.29),
}


def test_classes_fixed_order() -> None:
    assert CLASSES == ("reef_a", "reef_b", "reef_c", "sphere", "hemisphere", "pipe", "half_pipe", "box")
    assert set(BUILDERS) == set(CLASSES)


@pytest.mark.parametrize("name", CLASSES)
def test_mesh_frame_and_size(name: str) -> None:
    v, f = mesh_for(name)
    assert v.dtype == np.float64 and v.shape[1] == 3
    assert f.dtype == np.int32 and f.shape[1] == 3 and f.min() >= 0 and f.max() < len(v)
    lo, hi = v.min(axis=0), v.max(axis=0)
    assert hi[2] == pytest.approx(0.0, abs=1e-9)  # rests on the seabed (z down)
    assert lo[2] < -0.25  # sticks up
    np.testing.assert_allclose((lo[:2] + hi[:2]) / 2, 0.0, atol=1e-6)  # footprint centred
    if name in SIZES:
        np.testing.assert_allclose(hi - lo, SIZES[name], atol=2e-3)
    if name.startswith("reef"):
        ext = hi - lo
        assert 1.5 <= ext[:2].max() <= 2.0 and 1.2 <= ext[2] <= 1.8
    assert not v.flags.writeable and mesh_for(name)[0] is v  # cached, read-only


@pytest.mark.parametrize("name", CLASSES)
def test_components_closed_with_outward_normals(name: str) -> None:
    for part in BUILDERS[name]():
        assert part.is_watertight and part.is_winding_consistent
        assert part.volume > 0  # outward normals


def test_single_meshes_are_closed_outward_in_object_frame() -> None:
    import trimesh

    for name in ("sphere", "hemisphere", "pipe", "half_pipe", "box"):
        v, f = mesh_for(name)
        m = trimesh.Trimesh(v, f, process=True)
        assert m.is_watertight and m.volume > 0
    v, f = mesh_for("sphere")
    assert trimesh.Trimesh(v, f).volume == pytest.approx(4 / 3 * np.pi * 0.5**3, rel=0.02)
    v, f = mesh_for("hemisphere")
    assert trimesh.Trimesh(v, f).volume == pytest.approx(2 / 3 * np.pi * 0.5**3, rel=0.02)


def test_reefs_differ_in_structure() -> None:
    counts = {n: len(mesh_for(n)[1]) for n in ("reef_a", "reef_b", "reef_c")}
    assert len(set(counts.values())) == 3
    bs = [bounding_sphere(n)[1] for n in ("reef_a", "reef_b", "reef_c")]
    assert max(bs) / min(bs) < 1.25  # similar size


def test_bounding_sphere_encloses() -> None:
    for name in CLASSES:
        v, _ = mesh_for(name)
        c, r = bounding_sphere(name)
        assert np.linalg.norm(v - c, axis=1).max() <= r + 1e-12


def test_materials() -> None:
    assert class_material("reef_a").name == "concrete"
    assert class_material("sphere").reflection == pytest.approx(0.935, abs=0.01)
    assert 0.0 < class_material("reef_b").reflection < class_material("box").reflection < 1.0


def test_placed_on_flat_seabed_with_heading() -> None:
    sb = SeabedSurface(Seabed(depth=20.0))
    v, _ = placed_mesh(SceneObject("pipe", 30.0, 12.0, 90.0), sb)
    assert v[:, 2].max() == pytest.approx(20.0)
    assert v[:, 2].min() == pytest.approx(19.4)
    # heading 90: the 3 m axis points east
    np.testing.assert_allclose(v[:, 1].max() - v[:, 1].min(), 3.0, atol=1e-6)
    np.testing.assert_allclose(v[:, 0].max() - v[:, 0].min(), 0.6, atol=1e-3)
    np.testing.assert_allclose([(v[:, 0].max() + v[:, 0].min()) / 2, (v[:, 1].max() + v[:, 1].min()) / 2],
                               [30.0, 12.0], atol=1e-6)


def test_placed_on_slope_rests_on_the_plane() -> None:
    sb = SeabedSurface(Seabed(depth=20.0, slope_deg=10.0, slope_azimuth_deg=45.0))
    v, _ = placed_mesh(SceneObject("box", 5.0, -3.0, 20.0), sb)
    gap = sb.depth(v[:, 0], v[:, 1]) - v[:, 2]  # height above the seabed
    assert gap.min() == pytest.approx(0.0, abs=1e-9)  # bottom face lies on the plane
    assert np.sort(gap)[:4] == pytest.approx(0.0, abs=1e-9)
    # tilted with the plane: 0.6 m along the normal, 0.6 / cos(slope) vertically
    assert gap.max() == pytest.approx(0.6 / np.cos(np.radians(10.0)), abs=1e-9)


def test_placed_on_rough_seabed_touches_it() -> None:
    sb = SeabedSurface(Seabed(depth=20.0, roughness=0.02), seed=5)
    for name in ("sphere", "reef_c"):
        v, _ = placed_mesh(SceneObject(name, 11.0, 4.0, 0.0), sb)
        assert abs(v[:, 2].max() - float(sb.depth(11.0, 4.0))) < 1e-9
