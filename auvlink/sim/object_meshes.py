"""The object catalog: one procedural mesh per class, and objects placed on the seabed.

Meshes are in the object's own frame: x forward (north at heading 0), y starboard, z down, origin
at the centre of the footprint on the seabed, so an object of height ``h`` occupies
``z in [-h, 0]``. Sizes (length x width x height, m):

======== =================================================================
reef_a   cube-frame reef 1.6 x 1.6 x 1.5 (posts, rings, X braces)
reef_b   arch-tunnel reef 2.0 x 1.5 x 1.29 (slab, three arches on legs)
reef_c   pyramid-frame reef 1.83 x 1.84 x 1.7 (slanted legs, rings, column)
sphere   1.0 diameter
hemisphere 1.0 diameter, 0.5 high, flat side down
pipe     lying cylinder 3.0 long, 0.6 diameter
half_pipe lying half cylinder 3.0 x 0.6 x 0.3, 5 cm wall, open side down
box      1.2 x 0.8 x 0.6
======== =================================================================

Each component is watertight with outward normals; reefs are unions of overlapping components.
A placed object sits at ``(north, east, D(north, east))`` on the seabed, turned by its heading
about the vertical and tilted with the mean seabed plane.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np
import trimesh
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from auvlink.sim.mesh_builders import BUILDERS
from auvlink.sim.scene import CLASSES, SceneObject
from auvlink.sim.seabed import SeabedSurface

__all__ = [
    "CLASSES", "MATERIALS", "WATER_IMPEDANCE", "Material", "bounding_sphere", "class_material",
    "mesh_for", "object_pose", "placed_mesh",
]

F64 = NDArray[np.float64]
I32 = NDArray[np.int32]

# Build frame (z up, base at z = 0) -> object frame (FRD, z down): a half turn about x.
_UP_TO_FRD = np.diag([1.0, -1.0, -1.0])


@dataclass(frozen=True)
class Material:
    """Acoustic constants for the return model ``I = w (z - z0) / (z + z0) I0 cos^2(a) / r^2``."""

    name: str
    impedance: float  # z, Rayl (kg m^-2 s^-1)
    weight: float = 1.0  # w, scattering weight

    @property
    def reflection(self) -> float:
        """Pressure reflection coefficient against water, ``(z - z0) / (z + z0)``."""
        return (self.impedance - WATER_IMPEDANCE) / (self.impedance + WATER_IMPEDANCE)


WATER_IMPEDANCE = 1.54e6  # z0: sea water, 1025 kg/m^3 x 1500 m/s
MATERIALS: dict[str, Material] = {
    "sand": Material("sand", 3.1e6, 1.0),  # seabed: R ~ 0.34
    "concrete": Material("concrete", 8.0e6, 1.0),  # reefs: R ~ 0.68
    "steel": Material("steel", 46.0e6, 1.0),  # R ~ 0.94
}
_CLASS_MATERIAL = {
    "reef_a": "concrete", "reef_b": "concrete", "reef_c": "concrete", "sphere": "steel",
    "hemisphere": "steel", "pipe": "steel", "half_pipe": "steel", "box": "steel",
}


def class_material(class_name: str) -> Material:
    return MATERIALS[_CLASS_MATERIAL[class_name]]


@cache
def mesh_for(class_name: str) -> tuple[F64, I32]:
    """``(vertices (N, 3) float64, triangles (M, 3) int32)`` of a class in its object frame.

    Cached and read-only; copy before changing.
    """
    if class_name not in BUILDERS:
        raise KeyError(f"unknown object class {class_name!r}; known: {', '.join(CLASSES)}")
    parts = BUILDERS[class_name]()
    merged = trimesh.util.concatenate(parts) if len(parts) > 1 else parts[0]
    assert isinstance(merged, trimesh.Trimesh)
    v = np.ascontiguousarray(np.asarray(merged.vertices, float) @ _UP_TO_FRD)
    f = np.ascontiguousarray(np.asarray(merged.faces, np.int32))
    # the half turn is a proper rotation, so the winding (outward normals) is kept
    v.flags.writeable = False
    f.flags.writeable = False
    return v, f


@cache
def bounding_sphere(class_name: str) -> tuple[F64, float]:
    """``(centre (3,) in the object frame, radius)`` enclosing every vertex of the class."""
    v, _ = mesh_for(class_name)
    c = (v.min(axis=0) + v.max(axis=0)) / 2.0
    c.flags.writeable = False
    return c, float(np.sqrt(((v - c) ** 2).sum(axis=1).max()))


def object_pose(obj: SceneObject, seabed: SeabedSurface) -> tuple[F64, Rotation]:
    """World pose of an object: position (NED, on the seabed) and ``R_WO``."""
    down = -_plane_normal(seabed)  # tilt with the mean plane, not with the roughness
    ez = np.array([0.0, 0.0, 1.0])
    axis = np.cross(ez, down)
    angle = np.arctan2(np.linalg.norm(axis), ez @ down)
    tilt = Rotation.from_rotvec(axis / np.linalg.norm(axis) * angle) if angle > 1e-12 else Rotation.identity()
    rot = tilt * Rotation.from_euler("z", obj.heading_deg, degrees=True)
    pos = np.array([obj.north, obj.east, float(seabed.depth(obj.north, obj.east))])
    return pos, rot


def _plane_normal(seabed: SeabedSurface) -> F64:
    g = seabed.grad_plane
    n = np.array([g[0], g[1], -1.0])
    return n / np.linalg.norm(n)


def placed_mesh(obj: SceneObject, seabed: SeabedSurface) -> tuple[F64, I32]:
    """The object's mesh in the world NED frame, resting on the seabed."""
    v, f = mesh_for(obj.class_name)
    pos, rot = object_pose(obj, seabed)
    return v @ rot.as_matrix().T + pos, f.copy()
