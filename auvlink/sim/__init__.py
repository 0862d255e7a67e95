"""Simulator backend: a scene, a vehicle flying a lawnmower survey over it, and its sonar images.

Modules (imported on use; only :mod:`~auvlink.sim.scene` is light, the rest load Open3D/trimesh):

- :mod:`auvlink.sim.scene` scene TOML -> frozen dataclasses (:func:`load_scene`,
  :func:`load_default_scene`); the object catalog's class names (:data:`CLASSES`).
- :mod:`auvlink.sim.object_meshes` one procedural mesh per class (:func:`~auvlink.sim.object_meshes.mesh_for`),
  objects placed on the seabed (:func:`~auvlink.sim.object_meshes.placed_mesh`).
- :mod:`auvlink.sim.seabed` analytic sloped, rough seabed and ray intersection.
- :mod:`auvlink.sim.trajectory` the vehicle's true pose, velocities and rates over time.
- :mod:`auvlink.sim.sonar_render` sonar frames (range bins x beams of the sonar model, uint8) by ray casting.
"""

from auvlink.sim.scene import (
    CLASSES,
    Scene,
    SceneObject,
    Seabed,
    SonarConfig,
    Survey,
    Vehicle,
    load_default_scene,
    load_scene,
    loads_scene,
    parse_scene,
)

__all__ = [
    "CLASSES", "Scene", "SceneObject", "Seabed", "SonarConfig", "Survey", "Vehicle",
    "load_default_scene", "load_scene", "loads_scene", "parse_scene",
]
