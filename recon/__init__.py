"""3D reconstruction from a forward-scan sonar: navigation, highlight extension, seabed, clustering.

Pure computation on numpy arrays and small frozen dataclasses (no ports, no files except :mod:`recon.ply`).
Recon against the simulator's ground truth is evaluation, in the application layer
(:mod:`auvlink.evaluation.simeval`). Modules:

- navigation: :mod:`recon.frames` (attitudes, mountings, RDI frames), :mod:`recon.nav_samples` (the sensors' samples),
  :mod:`recon.nav` (batch dead reckoning),
  :mod:`recon.nav_stream` with :mod:`recon.nav_stream_lib` (causal dead reckoning), :mod:`recon.nav_anchor`
  (GNSS anchoring), :mod:`recon.trajectory` (pose interpolation);
- the sonar and its targets: :mod:`recon.sonar_geometry` (beams, bins, rays, seabed onset),
  :mod:`recon.beam_edge` (the fan's effective lower edge, estimated from the data), :mod:`recon.pattern_fall` (the
  beam pattern's fall beyond it) with :mod:`recon.echo_mosaic` (how much brighter than the seabed each patch
  echoes: where a brighter reflector was seen), :mod:`recon.range_arcs`
  (a return's range arc), :mod:`recon.target_envelope` (the smallest and largest object
  and the limits derived from them);
- the reconstruction: :mod:`recon.reconstructor` (:class:`Reconstructor`, the stages in order) with
  :mod:`recon.recon_config` (:class:`ReconConfig`); stage 1 :mod:`recon.onset_stage` (with
  :mod:`recon.seabed_band`: the seabed return of each column); stages 2-3 :mod:`recon.highlight` (returns, points;
  :mod:`recon.water_threshold`: the background before the onset; :mod:`recon.sidelobe`: a strong return's sidelobe
  arcs); :mod:`recon.exact_stats` (numpy's medians and percentiles, bit for bit, faster, for stages 1-3);
  stage 4 :mod:`recon.seabed_evidence` into :mod:`recon.seabed_memory` (with :mod:`recon.seabed`: tiled planes, their
  arithmetic in :mod:`recon.seabed_irls`,
  :mod:`recon.seabed_texture`: the texture grid); stage 5 :mod:`recon.object_stage` (with :mod:`recon.poll_seabed`:
  seabed removal and clutter, :mod:`recon.cluster` (with :mod:`recon.cluster_grid`), :mod:`recon.cluster_stream`,
  :mod:`recon.cluster_index`,
  :mod:`recon.fusion`: clustering across passes, :mod:`recon.arc_consensus` (where the arcs of a return's frames
  meet), :mod:`recon.front_slope` and :mod:`recon.far_side`: the final objects' points and centroids,
  :mod:`recon.shape`: footprints), :mod:`recon.shadow` (each final object's top height from its acoustic shadows
  in the seabed band);
- :mod:`recon.image_pooling` (frames finer than recon's sampling pooled to it), :mod:`recon.errors`,
  :mod:`recon.ply` (PLY output), :mod:`recon.synthetic` (frames from analytic shapes, for
  tests and benchmarks).
"""

from recon.cluster import ClusterConfig, DetectedObject, cluster
from recon.cluster_stream import StreamingClusterer
from recon.errors import GeometryError, NavigationError, ReconError
from recon.frames import Mounting, attitude
from recon.highlight import HighlightConfig, extract
from recon.nav import DepthSamples, DvlSamples, GyroSamples, NavConfig, dead_reckon, pressure_to_depth
from recon.recon_config import ReconConfig
from recon.reconstructor import Reconstructor
from recon.seabed import SeabedConfig, SeabedModel, object_mask
from recon.sonar_geometry import SonarGeometry
from recon.trajectory import Trajectory

__all__ = [
    "ClusterConfig", "DepthSamples", "DetectedObject", "DvlSamples", "GeometryError", "GyroSamples",
    "HighlightConfig", "Mounting", "NavConfig", "NavigationError", "ReconConfig", "ReconError",
    "Reconstructor", "SeabedConfig", "SeabedModel", "SonarGeometry", "StreamingClusterer", "Trajectory",
    "attitude", "cluster", "dead_reckon", "extract", "object_mask", "pressure_to_depth",
]
