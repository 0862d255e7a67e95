"""Recon's settings: :class:`ReconConfig`, what a user of recon sets, with one table per stage.

The values recon derives instead of asking for are named where they are used, each with its source: the target
envelope (:mod:`recon.target_envelope`), the sonar's geometry (:class:`recon.sonar_geometry.SonarGeometry`), the
seabed sampling (:mod:`recon.seabed_memory`), the onset fit (:mod:`recon.onset_stage`), the seabed band
search (:data:`recon.seabed_band.SEABED_BAND`) and the texture grid (:data:`recon.seabed_texture.SEABED_TEXTURE`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from recon.cluster import ClusterConfig
from recon.far_side import FarSideConfig
from recon.highlight import HighlightConfig
from recon.seabed import SeabedConfig


@dataclass(frozen=True)
class ReconConfig:
    """What a user of recon sets; everything else is derived (:mod:`recon.target_envelope`, the sonar geometry)."""

    highlight: HighlightConfig = field(default_factory=HighlightConfig)
    seabed: SeabedConfig = field(default_factory=SeabedConfig)
    cluster: ClusterConfig = field(default_factory=ClusterConfig)
    front_slope: bool = True  # correct the front slope: points re-placed on their range arcs (recon.front_slope)
    front_slope_length: float = 1.0  # m: how far behind a point its object's top is sought
    front_slope_width: float = 0.25  # m: across the look direction
    far_side: FarSideConfig = field(default_factory=FarSideConfig)  # with front_slope: centroid (recon.far_side)
    # recon calibrated from the frames: the fan's lower edge estimated from the seabed onset (recon.beam_edge) in place
    # of the nominal tilt + spread / 2, thresholds per range row of at least the grey level at which the seabed shows
    # there, the background before the onset (recon.water_threshold), the row across the fan
    # (recon.highlight.row_thresholds) and the sidelobe arcs of the row's strongest return (recon.sidelobe),
    # interfered frames counted. False: the nominal edge and the frame's water-column threshold alone (benchmarks)
    calibrate: bool = True
    # with calibrate: each final object re-placed below the effective edge by as much as it echoes brighter than the
    # seabed, through the beam pattern's measured fall (recon.pattern_fall, recon.echo_mosaic). Off by default: it
    # centres the objects' heights on soft beams (0.3 m too high before), but the shipped classifier was trained on
    # clouds placed on the edge and names the corrected ones worse; on once the synthesis emulates it
    below_edge: bool = False
    # each final object's returns re-placed below the elevation they were placed at, where the range arcs of their
    # successive frames meet (recon.arc_consensus: a fixed reflector seen through the beam's energy beyond the edge);
    # off by default until the classifier's synthesis places points alike (a classifier trained on edge-placed clouds)
    arc_consensus: bool = False
    # with calibrate: each final object's top height over the seabed measured from its acoustic shadows in the seabed
    # band (recon.shadow: two ranges along a beam, independent of the beam pattern), DetectedObject.shadow_height
    shadow_height: bool = True
    # two-way sidelobe level (dB re the main lobe) below which a return in the row of a stronger one is its sidelobe
    # (recon.sidelobe): the highest of the supported sonars' (DIDSON's lens, issue 36: -25 dB; ARIS -30 dB)
    sidelobe_db: float = -25.0
    display_range_db: float = 60.0  # dB the 8-bit log display spans (DIDSON/ARIS viewers' default)
