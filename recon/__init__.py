"""3D reconstruction from a forward-scan sonar: navigation, highlight extension, seabed, clustering.

Pure computation on numpy arrays and small frozen dataclasses (no ports, no files except
:mod:`recon.ply`). Modules: :mod:`recon.frames` (attitudes, mountings, RDI frames), :mod:`recon.nav`
(dead reckoning) and :mod:`recon.trajectory` (pose interpolation), :mod:`recon.sonar_geometry`,
:mod:`recon.highlight` and :mod:`recon.front_slope` (highlight-extension points), :mod:`recon.seabed`,
:mod:`recon.cluster` (with :mod:`recon.cluster_index`), :mod:`recon.far_side` (centroids: the hidden far side),
:mod:`recon.pipeline` (:class:`Reconstructor`), :mod:`recon.ply`, :mod:`recon.synthetic` (frames from analytic
shapes, for tests and benchmarks). Recon against the simulator's ground truth is evaluation, in the application
layer: :mod:`auvlink.evaluation.simeval`.
"""

from recon.cluster import ClusterConfig, DetectedObject, cluster
from recon.cluster_stream import StreamingClusterer
from recon.errors import GeometryError, NavigationError, ReconError
from recon.frames import Mounting, attitude
from recon.highlight import HighlightConfig, extract
from recon.nav import DepthSamples, DvlSamples, GyroSamples, NavConfig, dead_reckon, pressure_to_depth
from recon.pipeline import ReconConfig, Reconstructor
from recon.seabed import SeabedConfig, SeabedModel, object_mask
from recon.sonar_geometry import SonarGeometry
from recon.trajectory import Trajectory

__all__ = [
    "ClusterConfig", "DepthSamples", "DetectedObject", "DvlSamples", "GeometryError", "GyroSamples",
    "HighlightConfig", "Mounting", "NavConfig", "NavigationError", "ReconConfig", "ReconError",
    "Reconstructor", "SeabedConfig", "SeabedModel", "SonarGeometry", "StreamingClusterer", "Trajectory",
    "attitude", "cluster", "dead_reckon", "extract", "object_mask", "pressure_to_depth",
]
