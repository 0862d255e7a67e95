"""Single simulated sonar images of catalog objects for the 2D baseline (uses :mod:`auvlink.sim`).

One object of a class sits at the origin of a flat, slightly rough seabed, turned by a viewing
heading; the vehicle flies level towards it (yaw 0) at ``altitude`` with the sonar tilted by
``tilt``, and the frame is rendered (the idealized acoustic model, ``profile = "ideal"``; speckle on)
with the object at a horizontal distance drawn between where the steepest ray and the boresight
meet the seabed. Images are 512 x 96, reduced to ``(512 / pool) x 96`` by mean pooling along range.
Same settings, same images.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import os
import zlib
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from auvlink.progress import progress_bar
from auvlink.sim.acoustics import AcousticsTable
from auvlink.sim.scene import Scene, SceneObject, Seabed, SonarConfig, Survey
from auvlink.sim.sonar_render import SonarRenderer
from classify.training.baseline2d import ImageSet

#: the acoustic model the baseline's images are rendered under: the idealized one (``profile = "ideal"``)
IDEAL = AcousticsTable(profile="ideal")


@dataclass(frozen=True)
class ImageSettings:
    headings_deg: tuple[float, ...] = tuple(float(h) for h in range(0, 360, 20))
    tilts_deg: tuple[float, ...] = (20.0, 28.3333, 36.6667, 45.0)
    altitude_m: tuple[float, float] = (4.0, 6.0)
    spread_deg: float = 14.0
    depth_m: float = 20.0
    roughness_m: float = 0.02
    window_start: float = 1.0
    window_length: float = 10.0
    rays_per_beam: int = 16
    pool: int = 4
    copies: int = 1
    seed: int = 0


def render_images(class_names: Sequence[str], settings: ImageSettings, progress: bool = False,
                  cache_dir: Path | None = None) -> ImageSet:
    """One image per (class, heading, tilt, copy); labels index ``class_names``; cached as ``.npz``
    under ``cache_dir`` (keyed by a hash of the settings and class names) when given."""
    path = None
    if cache_dir is not None:
        key = hashlib.sha256(json.dumps({"v": 1, "classes": list(class_names), **asdict(settings)},
                                        sort_keys=True).encode()).hexdigest()[:20]
        path = Path(cache_dir) / f"images-{key}.npz"
        if path.is_file():
            with np.load(path) as z:
                return ImageSet(z["images"], z["labels"], tuple(class_names))
    out = _render(class_names, settings, progress)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.stem + f".{os.getpid()}.tmp.npz")
        np.savez_compressed(tmp, images=out.images, labels=out.labels)
        os.replace(tmp, path)
    return out


def _render(class_names: Sequence[str], settings: ImageSettings, progress: bool) -> ImageSet:
    images, labels = [], []
    seabed = Seabed(depth=settings.depth_m, roughness=settings.roughness_m)
    jobs = [(c, h, t, k) for c in range(len(class_names)) for h in settings.headings_deg
            for t in settings.tilts_deg for k in range(settings.copies)]
    for label, heading, tilt, copy in progress_bar(jobs, enabled=progress, desc="render", leave=False):
        name = class_names[label]
        rng = np.random.default_rng(np.random.SeedSequence(
            [settings.seed, zlib.crc32(name.encode()), round(heading * 1000), round(tilt * 1000), copy]))
        altitude = float(rng.uniform(*settings.altitude_m))
        sonar = SonarConfig(tilt_deg=tilt, window_start=settings.window_start,
                            window_length=settings.window_length, fps=10.0, spread_deg=settings.spread_deg,
                            rays_per_beam=settings.rays_per_beam)
        scene = Scene(seed=int(rng.integers(2**31)), seabed=seabed,
                      objects=(SceneObject(name, 0.0, 0.0, heading),),
                      survey=Survey(line_length=10.0, line_spacing=3.5, lines=1, altitude=altitude, speed=1.0),
                      sonar=sonar, acoustics=IDEAL)
        renderer = SonarRenderer(scene)
        t = math.radians(tilt)
        near = altitude / math.tan(t + math.radians(settings.spread_deg) / 2)
        far = min(altitude / math.tan(t), settings.window_start + 0.8 * settings.window_length)
        dist = float(rng.uniform(near, max(near, far)))
        pos = np.array([-dist, float(rng.uniform(-0.3, 0.3)), settings.depth_m - altitude])
        img = renderer.render(pos, 0.0, 0.0, 0.0, rng).astype(np.float32)
        p = settings.pool
        img = img[: img.shape[0] // p * p].reshape(-1, p, img.shape[1]).mean(axis=1)
        images.append((img / 255.0).astype(np.float32))
        labels.append(label)
    return ImageSet(np.stack(images), np.asarray(labels, dtype=np.int64), tuple(class_names))


def heldout_image_settings(settings: ImageSettings) -> ImageSettings:
    """Viewing headings shifted by half a step, tilts between the training tilts, another seed."""
    from dataclasses import replace

    hs = sorted(settings.headings_deg)
    step = (hs[1] - hs[0]) if len(hs) > 1 else 20.0
    ts = sorted(settings.tilts_deg)
    tilts = [(a + b) / 2 for a, b in itertools.pairwise(ts)] or [ts[0] + 2.5]
    return replace(settings, headings_deg=tuple((h + step / 2) % 360.0 for h in hs), tilts_deg=tuple(tilts),
                   seed=settings.seed + 1000)
