"""An object's class from its cloud and its top's height as its acoustic shadow measures it.

Recon measures each object's top over the seabed from where its shadows start and end along the beams
(:mod:`recon.shadow`, :attr:`recon.cluster.DetectedObject.shadow_height`): two ranges, untouched by the vertical
beam pattern that lifts the highlight extension's points of a soft-edged beam by 0.1-0.45 m. A half pipe (0.3 m)
and a pipe (0.6 m) of one width, or a hemisphere (0.5 m) and a sphere (1.0 m) of one footprint, differ in that
height alone, which the cloud's own heights no longer tell apart under such beams.

The classifier's probabilities are weighed by how well each class's top height explains the measured one
(:func:`height_weights`): a class whose shape is solid (its checkpoint's ``shadow_tops_m``: every class whose
silhouette fills its outline, :func:`classify.training.solid_tops.solid_tops`) gets
``exp(-((h - top) / sigma)^2 / 2)``, ``sigma`` = :data:`SIGMA_M` + :data:`SIGMA_FRACTION` x top, at least
:data:`FLOOR` (a height can be wrong: a confident network keeps its class); every other class
(open frames the sonar sees through, whose shadow is not their top; ``clutter``) keeps weight 1. The weights peak
at 1, so a height can only take weight from the classes it contradicts, never raise a solid class over an open one.
No height (NaN: the object's shadows not seen), no weighing; a weighed row keeps its total (a score stays
comparable with the network's probabilities).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import numpy.typing as npt

#: m: the height's error on a level top: its two ranges are read on columns averaged over 0.1 m of range
#: (recon.shadow.SMOOTH_M, half of it each) over a seabed of the survey space's roughness (up to 0.08 m rms)
SIGMA_M = 0.05
#: of the top's height: rays that graze a rounded top off its crest read lower, and a long shadow's end is read
#: against a reference its own object shadowed frames before (recon.shadow)
SIGMA_FRACTION = 0.1
#: the least weight: the share of heights the model does not explain (on random acoustic surveys 4-5 % of the solid
#: objects' heights lie beyond 2 sigma of their tops), so a height overturns the network only where the network's
#: odds for its class are below 20:1
FLOOR = 0.05


def height_weights(heights: Sequence[float], class_names: Sequence[str], tops: Mapping[str, float]
                   ) -> npt.NDArray[np.float64]:
    """(len(heights), len(class_names)) weights of each class for each measured top height (m; NaN: none)."""
    h = np.asarray(heights, dtype=np.float64).reshape(-1, 1)
    top = np.array([tops.get(n, math.nan) for n in class_names], dtype=np.float64)[None, :]
    sigma = SIGMA_M + SIGMA_FRACTION * top
    with np.errstate(invalid="ignore"):
        w = np.maximum(FLOOR, np.exp(-0.5 * ((h - top) / sigma) ** 2))
    return np.where(np.isfinite(w), w, 1.0)


def weighed(prob: npt.ArrayLike, heights: Sequence[float] | None, class_names: Sequence[str],
            tops: Mapping[str, float] | None) -> npt.NDArray[np.float64]:
    """The probabilities (n, k) weighed by :func:`height_weights`, each row scaled back to its own total (rows
    without a height, or all without tops, as they are)."""
    p = np.asarray(prob, dtype=np.float64).reshape(-1, len(class_names))
    if heights is None or not tops:
        return p
    q = p * height_weights(heights, class_names, tops)
    scale = np.divide(p.sum(axis=1, keepdims=True), q.sum(axis=1, keepdims=True),
                      out=np.zeros((p.shape[0], 1)), where=q.sum(axis=1, keepdims=True) > 0)
    return np.where(scale > 0, q * scale, p)
