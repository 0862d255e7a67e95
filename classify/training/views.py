"""Training views of mode ``scan`` as recon hands them to the classifier: one pass, the union of several
(fused), partial, and the clouds of clutter; and how a view's points become a training cloud.

Recon classifies an object when the vehicle is past it, then again each time a later pass adds to it
(``recon.fusion``): the classifier sees single passes, unions of passes from the adjacent lines (the
opposite heading, another lateral offset) or from crossing lines, and parts of objects (at the edge of the
swath, or where a line starts or ends over the object). :func:`scan_view` draws one such view:

* with probability ``fused_prob`` the union of 2-3 passes (count from ``fused_passes``) at one altitude and
  tilt: the first along the scan direction, each later one along the opposite heading (7 in 10, an adjacent
  line of the lawnmower) or any heading (a crossing line), shifted horizontally by a misalignment drawn from
  ``misalign_m`` in a random direction (what dead reckoning leaves between lines);
* each pass is partial with probability ``partial_prob`` (:func:`classify.training.scan_synth.partial_pass`).

:func:`training_cloud` turns the points of any view (an object's, or a clutter cluster's,
:mod:`classify.training.clutter_synth`) into the stored cloud: ``n_points`` points with a drawn fraction of noise
points, normalized as the settings say. Every draw comes from the generator passed in.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from classify.normalize import normalize_cloud
from classify.training.scan_synth import scan_points
from classify.training.synthesis_settings import SynthesisSettings

F64 = npt.NDArray[np.float64]
F32 = npt.NDArray[np.float32]
ADJACENT_LINE_P = 0.7  # a later pass of a fused view: the adjacent line (opposite heading), else a crossing line


def scan_view(scene: Any, vertices: F64, heading_rad: float, tilt_rad: float, settings: SynthesisSettings,
              rng: np.random.Generator) -> F64:
    """The points (metres, object frame NED, seabed at ``z = 0``) of one view; see the module docstring."""
    n = 1
    if settings.fused_prob > 0 and rng.random() < settings.fused_prob:
        lo, hi = (round(v) for v in settings.fused_passes)
        n = int(rng.integers(lo, hi + 1))
    if n == 1:
        partial = settings.partial_prob > 0 and rng.random() < settings.partial_prob
        return scan_points(scene, vertices, heading_rad, tilt_rad, settings, rng, partial=partial)
    alt = float(rng.uniform(*settings.altitude_m))
    parts = []
    for j in range(n):
        heading = heading_rad
        if j > 0:
            heading = heading_rad + math.pi if rng.random() < ADJACENT_LINE_P else float(rng.uniform(0, 2 * math.pi))
        partial = settings.partial_prob > 0 and rng.random() < settings.partial_prob
        p = scan_points(scene, vertices, heading, tilt_rad, settings, rng, altitude=alt, partial=partial)
        if j > 0:
            a = float(rng.uniform(0.0, 2 * math.pi))
            p = p + np.array([math.cos(a), math.sin(a), 0.0]) * float(rng.uniform(*settings.misalign_m))
        parts.append(p)
    return np.concatenate(parts)


def training_cloud(surf: F64, settings: SynthesisSettings, rng: np.random.Generator, n_found: int,
                   seabed_z: float = 0.0) -> tuple[F32, npt.NDArray[np.bool_]]:
    """``n_points`` points of ``surf`` (metres; drawn with replacement when fewer) plus a fraction drawn from
    ``noise_fraction`` of ``n_found`` as Gaussian noise points, shuffled and normalized
    (:func:`classify.training.synthesis.normalize_cloud`, seabed at depth ``seabed_z``); and the noise mask."""
    n = settings.n_points
    frac = float(rng.uniform(*settings.noise_fraction))
    n_noise = min(round(frac * n_found), n - 1)
    n_surf = n - n_noise
    pick = rng.choice(len(surf), size=n_surf, replace=len(surf) < n_surf)
    surf = surf[pick]
    std = surf.std(axis=0) * settings.noise_scale
    noise = surf.mean(axis=0) + rng.standard_normal((n_noise, 3)) * std
    cloud = np.concatenate([surf, noise])
    is_noise = np.r_[np.zeros(n_surf, bool), np.ones(n_noise, bool)]
    perm = rng.permutation(n)
    out = normalize_cloud(cloud[perm], settings.scale_m, settings.z_ref, seabed_z).astype(np.float32)
    return out, is_noise[perm]
