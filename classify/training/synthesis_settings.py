"""How training clouds are synthesized: :class:`SynthesisSettings` (stored in checkpoints, hashed for the
synthesized-cloud cache key), shared by both synthesis modes (:mod:`classify.training.synthesis`, mode ``paper``;
:mod:`classify.training.scan_synth`, mode ``scan``)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from recon.highlight import span_bins


def _default_tilts() -> tuple[float, ...]:
    return tuple(float(round(t, 4)) for t in np.linspace(20.0, 45.0, 4))


@dataclass(frozen=True)
class SynthesisSettings:
    """How training clouds are synthesized (stored in checkpoints; hashed for the cache key)."""

    headings_deg: tuple[float, ...] = tuple(float(h) for h in range(0, 360, 20))
    tilts_deg: tuple[float, ...] = field(default_factory=_default_tilts)
    spread_deg: float = 14.0
    n_points: int = 1024
    noise_fraction: tuple[float, float] = (0.05, 0.15)
    noise_scale: float = 1.0
    altitude_m: tuple[float, float] = (4.0, 6.0)
    front_slope: bool = True
    column_m: float = 0.05
    incidence_power: float = 0.0
    min_incidence_cos: float = 0.0
    seabed_cut_m: tuple[float, float] = (0.0, 0.0)
    slope_only: bool = False
    candidates: int = 6000
    copies: int = 1
    seed: int = 0
    # mode "scan" (classify.training.scan_synth): recon's highlight extension emulated from the beam geometry
    mode: str = "paper"
    lateral_m: tuple[float, float] = (-1.0, 1.0)
    min_cos: tuple[float, float] = (0.0, 0.5)
    min_height_m: tuple[float, float] = (0.15, 0.15)
    rays_per_beam: int = 8
    step_m: float = 0.1
    onset_margin_m: float = 0.25
    range_sigma_m: float = 0.01
    cos_jitter: float = 0.0
    range_bias_m: tuple[float, float] = (0.0, 0.0)  # scan mode: detection lag of recon (m of range)
    # scan mode detection: "cos" (a ray's own incidence against min_cos) or "energy" (the returns of a beam's
    # rays summed per range bin, cos^2 (r0 / r)^2 / rays, against a threshold drawn from energy_threshold,
    # held for min_run bins: as the sonar image and recon's run-length threshold see them)
    detect: str = "cos"
    energy_threshold: tuple[float, float] = (0.02, 0.1)
    bin_m: float = 10.0 / 512
    min_run: int = 2
    run_span_m: float = 0.0  # m: min_run bins among this much range (recon.highlight); 0: consecutive bins
    correction: str = "none"  # scan mode: "arc" applies recon's front-slope correction (as the pipeline does)
    correction_length_m: float = 1.0
    correction_width_m: float = 0.25
    correction_blend: tuple[float, float] = (1.0, 1.0)  # fraction of the correction applied (drawn per view)
    # with the correction: returns first re-placed where their frames' arcs meet (recon.arc_consensus), as recon
    # does with ReconConfig.arc_consensus
    arc_consensus: bool = False
    # > 0: clouds are centred and divided by this many metres (the size stays a feature), not unit-sphere
    scale_m: float = 0.0
    # "mean": centred on the mean in 3D; "seabed" (needs scale_m > 0): centred horizontally only, z kept as
    # the height above the local seabed (the object's height is a feature; recon knows the seabed)
    z_ref: str = "mean"
    # mode "scan", fused and partial views (classify.training.views): a view is the union of 2-3 passes (their count
    # drawn from fused_passes) with probability fused_prob, each later pass shifted by misalign_m (m, random
    # direction: dead reckoning between lines); a pass sees only part of the object with probability partial_prob
    fused_prob: float = 0.0
    fused_passes: tuple[float, float] = (2.0, 3.0)
    misalign_m: tuple[float, float] = (0.0, 0.3)
    partial_prob: float = 0.0
    # clutter (classify.training.clutter_synth): clutter_clouds > 0 adds the class "clutter", that many clouds of what
    # recon makes of rough seabed patches with no object
    clutter_clouds: int = 0
    clutter_roughness_m: tuple[float, float] = (0.03, 0.10)  # m rms
    clutter_slope_deg: tuple[float, float] = (0.0, 10.0)
    clutter_altitude_m: tuple[float, float] = (3.0, 7.0)
    clutter_spacing: tuple[float, float] = (0.4, 0.8)  # line spacing, fraction of the swath at the onset
    clutter_step_m: tuple[float, float] = (0.04, 0.3)  # m flown between frames (speed / fps)
    clutter_lines: tuple[float, float] = (2.0, 3.0)  # lines per patch
    clutter_line_m: float = 16.0  # m
    # recon's threshold on the seabed's returns, in the units of energy_threshold (rendered frames over rough seabeds,
    # alone: counts of highlight and seabed returns as recon finds them at about 0.002)
    clutter_energy_threshold: tuple[float, float] = (0.0015, 0.003)
    clutter_rays_per_beam: int = 32  # rays per beam over the seabed (the simulator's default)
    clutter_poll_m: float = 1.0  # m flown between recon's polls (its seabed fit sees what came before)
    # objects on rough patches (classify.training.object_patch_synth): object_patch_views > 0 adds that many views per
    # class of the mesh lying on a drawn rough seabed, as recon's own seabed removal and clustering hand them over
    object_patch_views: int = 0
    object_patch_roughness_m: tuple[float, float] = (0.03, 0.10)  # m rms
    object_patch_lines: tuple[float, float] = (1.0, 3.0)  # lines past the object
    object_patch_lead_m: float = 4.0  # m: each line starts with its onset this far before the object
    object_patch_offset_m: float = 1.0  # m: a cluster centred farther from the object is not a view of it

    # domain randomization of mode "scan" (classify.training.scan_acoustics): a fraction dr_prob of the passes is
    # drawn over the acoustic space of issue 36 (the rest: the idealized sonar); each range's source:
    dr_prob: float = 0.0
    dr_pattern_weights: tuple[float, ...] = (1.0, 1.0, 1.0)  # uniform, gaussian, sinc2: auvlink.sim.acoustics shapes
    dr_extent: tuple[float, float] = (1.0, 4.0)  # x the -3 dB width: the scene schema's vertical_extent range
    dr_edge_level_db: tuple[float, float] = (-25.0, -8.0)  # recon.beam_edge's half-step of a 16-50 dB seabed contrast
    dr_edge_error_deg: float = 1.5  # sigma: frame-to-frame spread of recon.beam_edge's running median (assumed)
    dr_nominal_edge_prob: float = 0.2  # recon without calibration (ReconConfig.calibrate off) places on +s/2
    dr_azimuth_width_beams: tuple[float, float] = (0.8, 1.0)  # ARIS 3000 / DIDSON, ARIS 1800 data sheets
    dr_sidelobe_db: tuple[float, float] = (-35.0, -15.0)  # issue 36: sidelobe level -15 to -35 dB
    dr_pulse_bins: tuple[float, float] = (1.0, 4.0)  # issue 36: pulse 1-4 range bins
    # issue 36's gain +-10 dB and noise floor, as far as recon's image-statistics thresholds (recon.water_threshold)
    # leave them: assumed +-6 dB on the detection threshold
    dr_threshold_db: tuple[float, float] = (-6.0, 6.0)
    dr_tvg_db_per_m: tuple[float, float] = (-1.0, 1.0)  # half the eval's +-2 dB/m: recon's per-row thresholds
    # recon's seabed fitted under an object, realistic profiles: 0.56 m deep (sphere, didson, calibrated; 0 without)
    dr_seabed_bias_m: tuple[float, float] = (0.0, 0.6)
    dr_speckle_looks: float = 2.0  # the profiles' speckle_looks (ARIS sample frames, auvlink.sim.acoustics)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SynthesisSettings:
        kw: dict[str, Any] = {}
        for k in cls.__dataclass_fields__:
            if k in d:
                v = d[k]
                kw[k] = tuple(float(x) for x in v) if isinstance(v, list | tuple) else v
        return cls(**kw)

    @property
    def span_bins(self) -> int:
        """``run_span_m`` in bins of ``bin_m`` (at least ``min_run``), as recon counts it."""
        return span_bins(self.min_run, self.run_span_m, self.bin_m)

    @property
    def directions(self) -> list[tuple[float, float]]:
        """(heading, tilt) pairs in degrees, heading-major."""
        return [(h, t) for h in self.headings_deg for t in self.tilts_deg]
