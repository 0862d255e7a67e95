"""Procedural builders for the object catalog's meshes (trimesh primitives, z-up build frame).

Every builder returns a list of closed, consistently wound components in a *z-up* build frame
with the footprint centred on the origin and the base at ``z = 0``; :mod:`auvlink.sim.object_meshes`
turns the list into one mesh in the object's FRD frame (z down). Components may overlap (there is
no boolean engine here), each one is watertight with outward normals.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import trimesh
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

F64 = NDArray[np.float64]
Shape = list[trimesh.Trimesh]


def _moved(mesh: trimesh.Trimesh, rotation: Rotation | None = None,
           translation: Sequence[float] = (0.0, 0.0, 0.0)) -> trimesh.Trimesh:
    t = np.eye(4)
    if rotation is not None:
        t[:3, :3] = rotation.as_matrix()
    t[:3, 3] = translation
    return mesh.apply_transform(t)


def block(extents: Sequence[float], center: Sequence[float]) -> trimesh.Trimesh:
    """Axis-aligned box."""
    return _moved(trimesh.creation.box(extents=extents), None, center)


def beam(p0: Sequence[float], p1: Sequence[float], width: float, extend: bool = True) -> trimesh.Trimesh:
    """Square-section beam of side ``width`` between two points.

    ``extend`` lengthens both ends by ``width / 2`` (fills the corners of axis-aligned frames);
    diagonal braces and slanted legs end at the points so they do not poke out of the frame.
    """
    a, b = np.asarray(p0, float), np.asarray(p1, float)
    axis = b - a
    length = float(np.linalg.norm(axis))
    mesh = trimesh.creation.box(extents=(length + (width if extend else 0.0), width, width))
    rot, _ = Rotation.align_vectors(axis[None, :] / length, np.array([[1.0, 0.0, 0.0]]))
    return _moved(mesh, rot, (a + b) / 2.0)


def arc(r_in: float, r_out: float, width: float, a0: float, a1: float, sections: int = 24) -> trimesh.Trimesh:
    """Ring segment (rectangular section) in the x-z plane around the y axis, ``width`` along y.

    Angle 0 is +x, pi/2 is +z (up). Closed at both ends.
    """
    ang = np.linspace(a0, a1, sections + 1)
    c, s = np.cos(ang), np.sin(ang)
    corners = []  # per section: (r_in, -w), (r_out, -w), (r_out, +w), (r_in, +w)
    for r, y in ((r_in, -width / 2), (r_out, -width / 2), (r_out, width / 2), (r_in, width / 2)):
        corners.append(np.stack([r * c, np.full_like(c, y), r * s], axis=1))
    v = np.stack(corners, axis=1).reshape(-1, 3)  # index = 4 * section + corner
    faces = []
    for i in range(sections):
        for k in range(4):
            a, b = 4 * i + k, 4 * i + (k + 1) % 4
            faces += [[a, b, b + 4], [a, b + 4, a + 4]]
    last = 4 * sections
    faces += [[0, 2, 1], [0, 3, 2], [last, last + 1, last + 2], [last, last + 2, last + 3]]
    mesh = trimesh.Trimesh(v, np.asarray(faces), process=True)
    mesh.fix_normals()
    return mesh


# --- simple classes -------------------------------------------------------------------------
def sphere() -> Shape:
    """Sphere, 1.0 m diameter."""
    return [_moved(trimesh.creation.icosphere(subdivisions=3, radius=0.5), None, (0, 0, 0.5))]


def hemisphere() -> Shape:
    """Hemisphere, 1.0 m diameter, flat side down (revolved quarter circle, closed base)."""
    a = np.linspace(0.0, math.pi / 2, 17)
    profile = np.vstack([[0.0, 0.0], np.c_[0.5 * np.cos(a), 0.5 * np.sin(a)]])
    profile[-1] = [0.0, 0.5]
    return [trimesh.creation.revolve(profile, sections=48)]


def pipe() -> Shape:
    """Lying cylinder, 3.0 m long (along x) and 0.6 m in diameter."""
    cyl = trimesh.creation.cylinder(radius=0.3, height=3.0, sections=48)
    return [_moved(cyl, Rotation.from_euler("y", 90, degrees=True), (0, 0, 0.3))]


def half_pipe() -> Shape:
    """Lying half cylinder, 3.0 m long, 0.6 m wide, 5 cm wall, open side down."""
    shell = arc(0.25, 0.30, 3.0, 0.0, math.pi, sections=32)  # axis along y
    return [_moved(shell, Rotation.from_euler("z", 90, degrees=True))]  # axis along x


def box() -> Shape:
    """Box 1.2 (x) x 0.8 (y) x 0.6 (z) m."""
    return [block((1.2, 0.8, 0.6), (0, 0, 0.3))]


# --- artificial reefs -----------------------------------------------------------------------
def _ring(half: float, z: float, w: float) -> Shape:
    c = [(-half, -half), (half, -half), (half, half), (-half, half)]
    return [beam((*c[i], z), (*c[(i + 1) % 4], z), w) for i in range(4)]


def reef_a() -> Shape:
    """Cube-frame reef 1.6 x 1.6 x 1.5 m: posts, bottom and top rings, side X braces, top cross."""
    w, half, h = 0.14, 0.8 - 0.07, 1.5
    zb, zt = w / 2, h - w / 2
    parts: Shape = []
    for sx in (-1, 1):
        for sy in (-1, 1):
            parts.append(beam((sx * half, sy * half, zb), (sx * half, sy * half, zt), w))
    parts += _ring(half, zb, w) + _ring(half, zt, w)
    for sy in (-1, 1):  # X braces on the two sides (openings front and back)
        parts.append(beam((-half, sy * half, zb), (half, sy * half, zt), w * 0.8, extend=False))
        parts.append(beam((-half, sy * half, zt), (half, sy * half, zb), w * 0.8, extend=False))
    parts.append(beam((-half, -half, zt), (half, half, zt), w * 0.8, extend=False))
    parts.append(beam((-half, half, zt), (half, -half, zt), w * 0.8, extend=False))
    return parts


def reef_b() -> Shape:
    """Arch-tunnel reef 2.0 x 1.5 x 1.29 m: base slab, three arches on legs, a ridge beam."""
    slab, leg, r_out, t = 0.12, 0.45, 0.72, 0.15
    z0 = slab + leg
    parts: Shape = [block((2.0, 1.5, slab), (0, 0, slab / 2))]
    for x in (-0.8, 0.0, 0.8):
        a = arc(r_out - t, r_out, t, 0.0, math.pi, sections=24)  # in x-z plane; turn into y-z plane
        parts.append(_moved(a, Rotation.from_euler("z", 90, degrees=True), (x, 0.0, z0)))
        for y in (-(r_out - t / 2), r_out - t / 2):
            parts.append(block((t, t, leg + 0.02), (x, y, slab + leg / 2)))
    parts.append(beam((-0.8, 0.0, z0 + r_out - t / 2), (0.8, 0.0, z0 + r_out - t / 2), t))
    return parts


def reef_c() -> Shape:
    """Pyramid-frame reef 1.8 x 1.8 x 1.7 m: slanted legs, three rings, a central column."""
    w, h = 0.14, 1.7
    hb, ht = 0.9 - w / 2, 0.4 - w / 2
    zb, zt = w / 2, h - w / 2
    parts: Shape = _ring(hb, zb, w) + _ring(ht, zt, w) + _ring((hb + ht) / 2, (zb + zt) / 2, w * 0.8)
    for sx in (-1, 1):
        for sy in (-1, 1):
            parts.append(beam((sx * hb, sy * hb, zb), (sx * ht, sy * ht, zt), w, extend=False))
    parts.append(block((0.2, 0.2, h - w), (0, 0, (h - w) / 2 + w / 2)))
    return parts


BUILDERS: dict[str, Callable[[], Shape]] = {
    "reef_a": reef_a, "reef_b": reef_b, "reef_c": reef_c, "sphere": sphere,
    "hemisphere": hemisphere, "pipe": pipe, "half_pipe": half_pipe, "box": box,
}
