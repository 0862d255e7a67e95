"""How far below the effective edge a reflector brighter than the seabed is seen: the beam pattern's measured fall.

The effective edge (:mod:`recon.beam_edge`) is the elevation at which the *seabed* shows: where its echo, through
the two-way vertical beam pattern, reaches the half step between the water's level ``N`` and the seabed's ``P``.
A real beam has energy beyond that edge (a smooth pattern, sidelobes), so a reflector brighter than the seabed
(steel, rock) is already seen by steeper rays, where the pattern has fallen by as much as it is brighter; placed
on the edge ray, its returns stand too high (by decimetres on a soft pattern; a hard-edged beam sees nothing
beyond its edge, and its fall is a step).

The fall is measured on the same seabed onset, per frame: the elevations at which the seabed reaches lower
fractions ``f`` of the step (:data:`FALL_FRACTIONS`, :func:`recon.beam_edge.frame_edge_profile`) are those at which
the pattern has fallen ``(0.5 - f) (P - N)`` grey levels (dB on the log display) below its level at the edge.
:class:`PatternFall` keeps their running medians over the frames, as :class:`recon.beam_edge.BeamEdge` keeps the
edge's.

A reflector ``E`` grey levels brighter than the seabed where both are seen alike (:mod:`recon.echo_mosaic`) reaches
the seabed's onset level where the pattern has fallen ``E`` further: where the seabed reaches the fraction
``f = 0.5 - E / (P - N)`` of the step. :meth:`PatternFall.extra` gives that elevation beyond the edge, interpolated
in the measured fall: 0 for a reflector no brighter than the seabed, and never deeper than the lowest fraction
measured (no extrapolation beyond the data).
"""

from __future__ import annotations

from collections import deque

import numpy as np
from numpy.typing import NDArray

from recon.beam_edge import ONSET_STEP

F64 = NDArray[np.float64]

#: fractions of the water-to-seabed step at which the seabed onset is measured: the half step (the edge,
#: recon.beam_edge.ONSET_STEP) and three lower ones, an eighth of the step apart, down to an eighth above the water
#: (below that the water's speckle reaches the level as often as the seabed's rise does)
FALL_FRACTIONS = (ONSET_STEP, ONSET_STEP - 0.125, ONSET_STEP - 0.25, ONSET_STEP - 0.375)


class PatternFall:
    """Running medians of the extra elevation (rad, beyond the edge) at each of :data:`FALL_FRACTIONS` and of the
    water-to-seabed step (grey levels) over the last ``window`` frames (module docstring)."""

    def __init__(self, window: int, min_frames: int) -> None:
        self.min_frames = int(min_frames)
        self._extra: deque[F64] = deque(maxlen=int(window))
        self._step: deque[float] = deque(maxlen=int(window))

    def update(self, edges: F64, steps: F64) -> None:
        """Take a batch's frame profiles: elevations (F, K) at :data:`FALL_FRACTIONS` (rad), steps (F,)."""
        e = np.asarray(edges, np.float64).reshape(-1, len(FALL_FRACTIONS))
        s = np.asarray(steps, np.float64).reshape(-1)
        ok = np.all(np.isfinite(e), axis=1) & np.isfinite(s) & (s > 0)
        extra = np.maximum.accumulate(np.maximum(e[ok] - e[ok, :1], 0.0), axis=1)  # never shallower further out
        self._extra.extend(extra)
        self._step.extend(float(x) for x in s[ok])

    @property
    def ready(self) -> bool:
        """True once ``min_frames`` frames gave a whole profile."""
        return len(self._step) >= self.min_frames

    def profile(self) -> tuple[F64, float]:
        """The median extra elevation (rad) at each fraction (K,) and the median step (grey levels); zeros and NaN
        until :attr:`ready`. A fraction reached further out than a steady fall from the edge would put it (``k``
        times the first fraction's extra, ``k`` eighths of the step down) is not the main lobe's fall (a lobe's
        fall in dB steepens until its first null: the level was reached by the water's speckle, a sidelobe or the
        pattern's end): it and the lower ones are held at the last fraction that was."""
        if not self.ready:
            return np.zeros(len(FALL_FRACTIONS)), float("nan")
        extra = np.median(np.stack(list(self._extra)), axis=0)
        steady = np.cumprod(extra <= np.arange(len(extra)) * extra[min(1, len(extra) - 1)] + 1e-12).astype(bool)
        held = np.maximum.accumulate(np.where(steady, extra, 0.0))
        return held, float(np.median(np.fromiter(self._step, np.float64)))

    def extra(self, excess: F64 | float) -> F64:
        """Extra elevation (rad, >= 0, beyond the edge) at which reflectors ``excess`` grey levels brighter than the
        seabed are first seen; 0 until :attr:`ready` (module docstring)."""
        e = np.asarray(excess, np.float64)
        if not self.ready:
            return np.zeros(e.shape)
        extra, step = self.profile()
        fraction = 0.5 - np.nan_to_num(e, nan=0.0) / step
        xs = np.asarray(FALL_FRACTIONS)[::-1]  # np.interp wants increasing x: the fractions run down from the edge's
        return np.asarray(np.interp(fraction, xs, extra[::-1]), np.float64)  # clamped at both ends
