"""The top height of each class whose shape casts a whole shadow: what :mod:`classify.shadow_height` weighs an
object's measured shadow height against.

A shadow's top is the object's top only where the object is opaque to the sonar from the side: a sphere, a box, a
pipe; not an open frame (a reef of posts and braces), whose shadow is cast by whichever members the grazing ray
meets. :func:`silhouette_fill` measures that from the mesh: seen from the side at :data:`AZIMUTHS` azimuths, the
share of the outline (every cell under the silhouette's upper profile, :data:`CELL_M` cells) that the mesh's
surface covers. A class is solid when that share reaches :data:`SOLID_FILL` at half the azimuths or more (the
median): the catalogue's spheres, hemispheres, boxes and pipes fill 0.92-1.0 of their outline at every azimuth, a
half pipe seen end-on 0.6 (its arch is hollow; a grazing ray still meets its floor within its length), its reefs
0.39-0.83 (median 0.75-0.76).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from classify.training.dataset import MeshSource
from classify.training.synthesis import sample_surface

F64 = npt.NDArray[np.float64]

#: azimuths (rad) the silhouette is seen from: every 15 deg over a half turn (a silhouette and its mirror agree)
AZIMUTHS = np.deg2rad(np.arange(0.0, 180.0, 15.0))
#: m: the silhouette's cells (the shadow's height is read to ~5 cm, classify.shadow_height.SIGMA_M)
CELL_M = 0.05
#: surface samples per mesh: ~40 per cell of a 2 m x 2 m outline, none left empty by chance
SAMPLES = 200_000
#: of the outline the surface must cover, at half the azimuths or more, for a solid class (between the solids'
#: 0.92 and the open frames' 0.83 at best; module docstring)
SOLID_FILL = 0.9
#: what a checkpoint's ``shadow_tops_source`` says of its ``shadow_tops_m``
SHADOW_TOPS_SOURCE = "the training meshes' solid classes (classify.training.solid_tops)"


def silhouette_fill(vertices: npt.ArrayLike, triangles: npt.ArrayLike, seed: int = 0) -> F64:
    """Per azimuth of :data:`AZIMUTHS`, the share of the mesh's side outline its surface covers (module docstring);
    the mesh in NED metres, its base at z = 0 and its top at negative z."""
    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64)
    p = sample_surface(v, t, np.ones(len(t), bool), SAMPLES, np.random.default_rng(seed))
    height = p[:, 2].max() - p[:, 2]
    iz = np.floor(height / CELL_M).astype(np.int64)
    fills = []
    for az in AZIMUTHS:
        x = p[:, 0] * np.cos(az) + p[:, 1] * np.sin(az)
        ix = np.floor((x - x.min()) / CELL_M).astype(np.int64)
        occupied = np.zeros((int(ix.max()) + 1, int(iz.max()) + 1), bool)
        occupied[ix, iz] = True
        top = occupied.shape[1] - np.argmax(occupied[:, ::-1], axis=1)  # per column, cells up to its highest
        under = np.arange(occupied.shape[1])[None, :] < top[:, None]
        fills.append((occupied & under).sum() / under.sum())
    return np.asarray(fills, dtype=np.float64)


def solid_tops(names: Sequence[str], mesh_for: MeshSource) -> dict[str, float]:
    """Top height (m over its base) of every class in ``names`` whose mesh is solid (module docstring); the others
    (and names without a mesh, ``clutter``) are left out."""
    out: dict[str, float] = {}
    for name in names:
        try:
            vertices, triangles = mesh_for(name)
        except (KeyError, ValueError):
            continue
        v: Any = np.asarray(vertices, dtype=np.float64)
        if float(np.median(silhouette_fill(v, triangles))) >= SOLID_FILL:
            out[name] = round(float(v[:, 2].max() - v[:, 2].min()), 4)
    return out


def write_solid_tops(model: Path, out: Path, mesh_for: MeshSource) -> Path:
    """A copy of the checkpoint ``model`` at ``out`` (and its inference export) whose calibration holds the
    :func:`solid_tops` of its classes."""
    from classify.checkpoint import load_checkpoint, save_recalibrated

    ck = load_checkpoint(model)
    return save_recalibrated(ck, out, {**ck.calibration, "shadow_tops_m": solid_tops(ck.class_names, mesh_for),
                                       "shadow_tops_source": SHADOW_TOPS_SOURCE})
