"""The acoustic conditions of one training view of mode ``scan``, drawn over the acoustic space of issue 36
(domain randomization): no sonar profile is the one the classifier learns.

:func:`draw_acoustics` draws, per pass, from the ``dr_*`` ranges of
:class:`classify.training.synthesis_settings.SynthesisSettings` (each range's source there):

* with probability ``1 - dr_prob`` the idealized sonar (hard vertical edge at the nominal ``+-s/2``, one azimuth
  per beam, no pulse, no speckle, no TVG error: the synthesis of before);
* else the two-way vertical beam pattern (shape ``uniform``/``gaussian``/``sinc2`` by ``dr_pattern_weights``,
  -3 dB at ``+-s/2``) sampled over ``vertical_extent`` nominal widths (energy beyond the edge, tapered to 0 over the
  outer 30 %, as :func:`auvlink.sim.acoustic_image.tapered_pattern`); the rays weighted by it (:func:`ray_weights`);
* the elevation recon places its highlight points on (:func:`effective_edge`): with probability
  ``dr_nominal_edge_prob`` the nominal ``+s/2`` (recon without calibration), else where the pattern falls to a level
  drawn from ``dr_edge_level_db`` (recon.beam_edge's midpoint of the water-to-seabed step) plus an estimation error
  of ``dr_edge_error_deg`` (gaussian sigma);
* the azimuth response of a beam to its neighbours (:func:`beam_leak`: a gaussian main lobe of
  ``dr_azimuth_width_beams`` and sidelobes at ``dr_sidelobe_db`` two beams off, falling as ``1/k^2``);
* a pulse of ``dr_pulse_bins`` range bins (an echo spread over ``[r, r + pulse]``), a detection threshold offset
  of ``dr_threshold_db`` (gain, noise floor, after recon's image-statistics thresholds), a TVG error of
  ``dr_tvg_db_per_m`` along range from the window's middle, and gamma speckle of ``dr_speckle_looks`` looks per
  range bin and beam; and recon's seabed under the object fitted ``dr_seabed_bias_m`` deeper (the cloud's heights
  above it, and its seabed removal, follow).

Every draw comes from the generator passed in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from classify.training.synthesis_settings import SynthesisSettings

F64 = npt.NDArray[np.float64]
PATTERNS = ("uniform", "gaussian", "sinc2")  # auvlink.sim.acoustics.PatternShape
SINC2_HALF_POWER = 0.442946470689452  # x where (sin(pi x) / (pi x))^2 = 1/2 (-3 dB at the nominal half spread)
TAPER_FRACTION = 0.3  # the simulator's taper: the outer 30 % of the sampled half extent (auvlink.sim.acoustic_image)
LEAK_BEAMS = 3  # beams each side a return leaks into; wider arcs fall under recon's across-fan row threshold
WINDOW_MIDDLE_M = 6.0  # m: the middle of the default 1-11 m window, where a TVG error is 0 (the simulator's r_mid)


@dataclass(frozen=True)
class ViewAcoustics:
    """One pass's acoustic conditions (module docstring). Angles in radians, off the fan's axis (+: down)."""

    pattern: str = "uniform"
    extent: float = 1.0  # sampled elevations, in nominal widths s
    edge_rad: float = 0.0  # where recon places points (0: the nominal s/2, set by draw_acoustics)
    leak: tuple[float, ...] = (1.0,)  # energy into beams -LEAK_BEAMS..+LEAK_BEAMS (centre 1)
    pulse_bins: int = 1
    threshold_factor: float = 1.0
    tvg_db_per_m: float = 0.0
    speckle_looks: float = 0.0  # 0: none
    seabed_bias_m: float = 0.0  # recon's seabed under the object fitted this much deeper (m)

    @property
    def ideal(self) -> bool:
        return self.pattern == "uniform" and self.extent <= 1.0 and len(self.leak) == 1 and self.pulse_bins <= 1


def pattern_gain(shape: str, spread: float, phi: F64, extent: float) -> F64:
    """Two-way power pattern at elevations ``phi`` (rad, off the axis), -3 dB at ``+-spread/2``, tapered to 0 over
    the outer 30 % of ``+-extent * spread / 2`` (a uniform pattern: 1 inside ``+-spread/2``, 0 outside)."""
    u = np.asarray(phi, float) / (spread / 2.0)
    if shape == "uniform":
        return (np.abs(u) <= 1.0 + 1e-9).astype(float)
    g = np.exp(-math.log(2.0) * u * u) if shape == "gaussian" else np.sinc(u * SINC2_HALF_POWER) ** 2
    half = extent * spread / 2.0
    taper = np.clip((half - np.abs(phi)) / (TAPER_FRACTION * half), 0.0, 1.0) if extent > 1.0 else (np.abs(u) <= 1.0)
    return np.asarray(g * taper, dtype=np.float64)


def effective_edge(shape: str, spread: float, extent: float, level_db: float) -> float:
    """The lowest elevation (rad) at which the tapered pattern is still at ``level_db`` (<= 0) of its peak: where
    the seabed's rising ramp crosses recon's edge criterion; at least the nominal ``spread / 2``."""
    if shape == "uniform" or extent <= 1.0:
        return spread / 2.0
    phi = np.linspace(0.0, extent * spread / 2.0, 400)
    above = np.flatnonzero(pattern_gain(shape, spread, phi, extent) >= 10.0 ** (level_db / 10.0))
    return max(spread / 2.0, float(phi[above[-1]]) if above.size else spread / 2.0)


def beam_leak(width_beams: float, sidelobe_db: float) -> tuple[float, ...]:
    """Energy a beam receives from the beams ``-LEAK_BEAMS..+LEAK_BEAMS`` off (two-way): a gaussian main lobe,
    -3 dB at ``+-width_beams / 2``, and sidelobes at ``sidelobe_db`` two beams off falling as ``1/k^2``
    (:func:`auvlink.sim.acoustic_image.beam_mixing`'s model)."""
    k = np.arange(-LEAK_BEAMS, LEAK_BEAMS + 1, dtype=float)
    main = np.exp(-math.log(2.0) * (2.0 * k / width_beams) ** 2)
    side = np.where(np.abs(k) >= 2, 10.0 ** (sidelobe_db / 10.0) * 4.0 / np.maximum(k * k, 1.0), 0.0)
    return tuple(float(x) for x in np.maximum(main, side))


def draw_acoustics(settings: SynthesisSettings, spread: float, rng: np.random.Generator) -> ViewAcoustics:
    """One pass's acoustic conditions (module docstring); the ideal sonar with probability ``1 - dr_prob``."""
    if settings.dr_prob <= 0.0 or rng.random() >= settings.dr_prob:
        return ViewAcoustics(edge_rad=spread / 2.0)
    w = np.asarray(settings.dr_pattern_weights, dtype=float)
    shape = PATTERNS[int(rng.choice(len(PATTERNS), p=w / w.sum()))]
    extent = 1.0 if shape == "uniform" else float(rng.uniform(*settings.dr_extent))
    if rng.random() < settings.dr_nominal_edge_prob:
        edge = spread / 2.0
    else:
        edge = effective_edge(shape, spread, extent, float(rng.uniform(*settings.dr_edge_level_db)))
        edge = max(0.5 * spread / 2.0, edge + math.radians(settings.dr_edge_error_deg) * float(rng.standard_normal()))
    width = float(rng.uniform(*settings.dr_azimuth_width_beams))
    leak = beam_leak(width, float(rng.uniform(*settings.dr_sidelobe_db)))
    lo, hi = (round(v) for v in settings.dr_pulse_bins)
    pulse = int(rng.integers(lo, hi + 1))
    return ViewAcoustics(pattern=shape, extent=extent, edge_rad=edge, leak=leak, pulse_bins=pulse,
                         threshold_factor=10.0 ** (float(rng.uniform(*settings.dr_threshold_db)) / 10.0),
                         tvg_db_per_m=float(rng.uniform(*settings.dr_tvg_db_per_m)),
                         speckle_looks=settings.dr_speckle_looks,
                         seabed_bias_m=float(rng.uniform(*settings.dr_seabed_bias_m)))


def ray_elevations(acoustics: ViewAcoustics, spread: float, rays_per_beam: int) -> F64:
    """Ray elevations (rad, off the axis, +: down) from the nominal upper edge ``-s/2`` to the sampled lower end
    (``+s/2``, or ``+extent s/2``), as densely as ``rays_per_beam`` over the nominal spread."""
    low = max(acoustics.extent * spread / 2.0, acoustics.edge_rad)
    k = max(2, round(rays_per_beam * (low + spread / 2.0) / spread))
    return np.linspace(-spread / 2.0, low, k)


def ray_weights(acoustics: ViewAcoustics, spread: float, elevations: F64) -> F64:
    """Per ray, its share of a beam's return ``(K,)``: the pattern times the elevation step over the nominal spread
    (the idealized sonar: ``1 / K`` each, summing to 1)."""
    if acoustics.pattern == "uniform":
        return np.full(len(elevations), 1.0 / len(elevations))
    step = (elevations[-1] - elevations[0]) / max(len(elevations) - 1, 1)
    return pattern_gain(acoustics.pattern, spread, elevations, acoustics.extent) * step / spread


def tvg_gain(acoustics: ViewAcoustics, t_hit: F64) -> F64:
    """Power factor of the TVG error at ranges ``t_hit`` (m; clipped to 0-20 m: no overflow on far rays)."""
    if acoustics.tvg_db_per_m == 0.0:
        return np.ones_like(t_hit)
    r = np.clip(np.nan_to_num(t_hit, posinf=20.0), 0.0, 20.0)
    return np.asarray(10.0 ** (acoustics.tvg_db_per_m * (r - WINDOW_MIDDLE_M) / 10.0))
