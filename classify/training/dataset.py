"""Synthesized cloud sets: every catalog class seen from every scan direction, cached on disk.

A :class:`CloudSet` holds ``points (M, N, 3)`` float32 (unit sphere), integer ``labels``, the class
names and the (heading, tilt) each cloud was synthesized for. :func:`synthesize_set` builds one
from a mesh source (``mesh_for(class_name) -> (vertices, triangles)``); each class is cached as an
``.npz`` named by a hash of the settings, the class name and the mesh bytes, so a change to any of
them synthesizes afresh. Each view draws from its own generator, spawned from
``SeedSequence([seed, crc32(class_name)])``: same settings, same clouds, in any order.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import os
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from auvlink.progress import progress_bar
from auvlink.sim.object_meshes import CLASSES, mesh_for
from classify.errors import SynthesisError
from classify.labels import CLUTTER
from classify.training.synthesis import MeshSynthesizer, SynthesisSettings

MeshSource = Callable[[str], tuple[npt.NDArray[Any], npt.NDArray[Any]]]
CACHE_VERSION = 2


@dataclass(frozen=True)
class CloudSet:
    points: npt.NDArray[np.float32]
    labels: npt.NDArray[np.int64]
    class_names: tuple[str, ...]
    headings_deg: npt.NDArray[np.float64]
    tilts_deg: npt.NDArray[np.float64]
    scale_m: float = 0.0  # SynthesisSettings.scale_m of the clouds (0: unit sphere)
    z_ref: str = "mean"  # SynthesisSettings.z_ref ("seabed": z is the height above the seabed, not centred)
    #: per cloud: made by recon's own seabed removal (clutter, objects on rough patches), so its seabed error is
    #: measured, not modelled (``AugmentConfig.seabed_error_on_measured``); None: none is
    measured: npt.NDArray[np.bool_] | None = None

    def __len__(self) -> int:
        return len(self.labels)

    def subset(self, idx: npt.NDArray[np.integer[Any]]) -> CloudSet:
        return CloudSet(self.points[idx], self.labels[idx], self.class_names, self.headings_deg[idx],
                        self.tilts_deg[idx], self.scale_m, self.z_ref,
                        None if self.measured is None else self.measured[idx])


def default_cache_dir() -> Path:
    """``$AUVLINK_CACHE/classify``, else ``~/.cache/auvlink/classify``."""
    root = os.environ.get("AUVLINK_CACHE")
    return (Path(root) if root else Path.home() / ".cache" / "auvlink") / "classify"


def catalog_meshes() -> tuple[tuple[str, ...], MeshSource]:
    """The simulator's object catalog: its class names and ``mesh_for``."""
    return tuple(CLASSES), mesh_for


def _cache_key(name: str, vertices: npt.NDArray[Any], triangles: npt.NDArray[Any],
               settings: SynthesisSettings) -> str:
    h = hashlib.sha256()
    flat = {k: v for k, v in settings.to_dict().items() if not k.startswith("object_patch_")}  # not used here
    h.update(json.dumps({"v": CACHE_VERSION, "class": name, "settings": flat}, sort_keys=True).encode())
    h.update(np.ascontiguousarray(vertices, dtype=np.float64).tobytes())
    h.update(np.ascontiguousarray(triangles, dtype=np.int64).tobytes())
    return h.hexdigest()[:20]


def synthesize_class(name: str, vertices: npt.NDArray[Any], triangles: npt.NDArray[Any],
                     settings: SynthesisSettings) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.float64]]:
    """Clouds ``(<= D * copies, N, 3)`` of one mesh and their (heading, tilt) in degrees (a view that gives
    no cloud, :class:`SynthesisError` from :meth:`MeshSynthesizer.view`, is left out)."""
    synth = MeshSynthesizer(vertices, triangles)
    dirs = settings.directions
    seeds = np.random.SeedSequence([settings.seed, zlib.crc32(name.encode())]).spawn(
        len(dirs) * settings.copies)
    clouds, meta = [], []
    for i, (heading, tilt) in enumerate(dirs):
        for c in range(settings.copies):
            rng = np.random.default_rng(seeds[i * settings.copies + c])
            try:
                cloud, _ = synth.view(math.radians(heading), math.radians(tilt), settings, rng)
            except SynthesisError:  # a direction the sonar cannot see the object from (a low half pipe)
                continue
            clouds.append(cloud)
            meta.append((heading, tilt))
    if not clouds:
        raise SynthesisError(f"no view of {name!r} gave a cloud (all {len(dirs) * settings.copies} failed)")
    return np.stack(clouds), np.asarray(meta, dtype=np.float64)


def _clutter_key(settings: SynthesisSettings, count: int) -> str:
    """Cache key of the clutter clouds: the settings, the count, and the source of the code that makes them
    (recon's seabed removal and clustering, the simulator's seabed: a change there gives other clutter)."""
    import recon
    from auvlink.sim import seabed
    from classify.training import clutter_synth, scan_synth, seabed_returns, views

    h = hashlib.sha256(json.dumps({"v": CACHE_VERSION, "class": CLUTTER, "count": count,
                                   "settings": settings.to_dict()}, sort_keys=True).encode())
    files = sorted(Path(str(recon.__file__)).parent.glob("*.py"))
    for f in [*files, *(Path(str(m.__file__)) for m in (seabed, clutter_synth, seabed_returns, scan_synth, views))]:
        h.update(f.read_bytes())
    return h.hexdigest()[:20]


def _patch_key(name: str, vertices: npt.NDArray[Any], triangles: npt.NDArray[Any], settings: SynthesisSettings) -> str:
    """Cache key of a class's views on rough patches: as :func:`_clutter_key`, with the class and its mesh."""
    from classify.training import object_patch_synth

    h = hashlib.sha256(_clutter_key(settings, settings.object_patch_views).encode())
    h.update(name.encode())
    h.update(Path(str(object_patch_synth.__file__)).read_bytes())
    h.update(np.ascontiguousarray(vertices, dtype=np.float64).tobytes())
    h.update(np.ascontiguousarray(triangles, dtype=np.int64).tobytes())
    return h.hexdigest()[:20]


def _cached(path: Path | None, make: Callable[[], tuple[npt.NDArray[Any], npt.NDArray[Any]]]
            ) -> tuple[npt.NDArray[Any], npt.NDArray[Any]]:
    """``(points, directions)`` from the ``.npz`` at ``path`` when it exists, else made and stored there."""
    if path is not None and path.is_file():
        with np.load(path) as z:
            return z["points"], z["directions"]
    clouds, dirs = make()
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.stem + f".{os.getpid()}.tmp.npz")
        np.savez_compressed(tmp, points=clouds, directions=dirs)
        os.replace(tmp, path)
    return clouds, dirs


def synthesize_set(class_names: Sequence[str], mesh_for: MeshSource, settings: SynthesisSettings,
                   cache_dir: Path | None = None, progress: bool = False) -> CloudSet:
    """All classes from all directions of ``settings`` (cached under ``cache_dir`` when given); the class
    ``clutter`` (:data:`classify.labels.CLUTTER`) is ``clutter_clouds`` clouds of seabed patches
    (:func:`classify.training.clutter_synth.synthesize_clutter`), not a mesh."""
    pts, labels, meta, measured = [], [], [], []
    for label, name in enumerate(progress_bar(class_names, enabled=progress, desc="synthesize", leave=False)):
        is_clutter = name == CLUTTER
        vertices, triangles = (np.zeros((0, 3)), np.zeros((0, 3), np.int64)) if is_clutter else mesh_for(name)
        path = None
        if cache_dir is not None:
            key = _clutter_key(settings, settings.clutter_clouds) if is_clutter else \
                _cache_key(name, vertices, triangles, settings)
            path = Path(cache_dir) / f"{name}-{key}.npz"
        if is_clutter:
            from classify.training.clutter_synth import synthesize_clutter

            clouds, dirs = _cached(path, partial(synthesize_clutter, settings, settings.clutter_clouds, progress))
            measured.append(np.ones(len(clouds), bool))
        else:
            clouds, dirs = _cached(path, partial(synthesize_class, name, vertices, triangles, settings))
            measured.append(np.zeros(len(clouds), bool))
            if settings.object_patch_views > 0:
                from classify.training.object_patch_synth import synthesize_object_patches

                patch_path = None if cache_dir is None else \
                    Path(cache_dir) / f"{name}-patch-{_patch_key(name, vertices, triangles, settings)}.npz"
                more, more_dirs = _cached(patch_path, partial(synthesize_object_patches, name, vertices, triangles,
                                                              settings, settings.object_patch_views))
                clouds, dirs = np.concatenate([clouds, more]), np.concatenate([dirs, more_dirs])
                measured.append(np.ones(len(more), bool))
        pts.append(clouds)
        labels.append(np.full(len(clouds), label, dtype=np.int64))
        meta.append(dirs)
    d = np.concatenate(meta)
    return CloudSet(np.concatenate(pts).astype(np.float32), np.concatenate(labels), tuple(class_names),
                    d[:, 0], d[:, 1], settings.scale_m, settings.z_ref, np.concatenate(measured))


def heldout_settings(settings: SynthesisSettings, seed: int | None = None) -> SynthesisSettings:
    """Directions and draws not used in training: headings shifted by half a step, tilts between the
    training tilts (and 2.5 deg beyond both ends), another seed, a wider altitude range."""
    hs = sorted(settings.headings_deg)
    step = (hs[1] - hs[0]) if len(hs) > 1 else 20.0
    ts = sorted(settings.tilts_deg)
    mids = [(a + b) / 2 for a, b in itertools.pairwise(ts)]
    tilts = [ts[0] + 2.5, *mids, ts[-1] - 2.5] if len(ts) > 1 else [ts[0] + 2.5]
    lo, hi = settings.altitude_m
    return replace(settings, headings_deg=tuple(float(h + step / 2) % 360.0 for h in hs),
                   tilts_deg=tuple(float(t) for t in tilts), altitude_m=(0.8 * lo, 1.2 * hi),
                   seed=settings.seed + 1000 if seed is None else seed,
                   object_patch_views=settings.object_patch_views // 3)


def stratified_split(labels: npt.NDArray[np.int64], val_fraction: float,
                     rng: np.random.Generator) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Indices (train, val) with ``val_fraction`` of each class in val (at least one when possible)."""
    train, val = [], []
    for c in np.unique(labels):
        idx = rng.permutation(np.nonzero(labels == c)[0])
        n_val = round(val_fraction * len(idx))
        if val_fraction > 0 and len(idx) > 1:
            n_val = max(1, n_val)
        val.append(idx[:n_val])
        train.append(idx[n_val:])
    return np.sort(np.concatenate(train)), np.sort(np.concatenate(val))
