"""The targets recon is built for, and the limits derived from them.

The envelope is the object catalogue (``auvlink/sim/object_meshes.py``, the classes the classifier names): the
largest object is 3.0 m long (the pipe and the half pipe), the lowest stands 0.3 m high (the half pipe).
Every size limit of recon follows from those two and from how the sonar sees them; a new catalogue with
other sizes changes these two numbers (``tests/test_recon_envelope.py`` checks them against the catalogue).
"""

from __future__ import annotations

#: m: the longest horizontal side of any catalogue object (pipe, half pipe: 3.0 m)
LARGEST_OBJECT_M = 3.0
#: m: the height of the lowest catalogue object (half pipe: 0.3 m)
LOWEST_OBJECT_M = 0.3
#: m: how much wider than the object its cluster grows: navigation drift between the passes over it and the
#: points of its flanks (0.75 m each side)
CLUSTER_BLUR_M = 1.5

#: m: a cluster wider than this is not one object (the largest object plus the cluster blur)
MAX_OBJECT_EXTENT_M = LARGEST_OBJECT_M + CLUSTER_BLUR_M
#: m: an object's top (95th percentile of its points over the seabed) stands at least half the lowest object
MIN_OBJECT_HEIGHT_M = LOWEST_OBJECT_M / 2
#: m: a top detected lower than this is not an object on any seabed: a third of the lowest object (the detected
#: top of a 0.3 m half pipe at 30 deg of tilt is 0.13-0.15 m: the steepest ray grazes its rounded top)
LOWEST_TOP_M = round(LOWEST_OBJECT_M / 3, 3)
#: m: the seabed-noise threshold of object points never exceeds two thirds of the lowest object's height (a
#: noise measured on a misregistered survey would otherwise put the lowest objects under the seabed)
MAX_SEABED_THRESHOLD_M = round(2 * LOWEST_OBJECT_M / 3, 3)
#: m: the points this near (horizontally) a point of an object's top are its flanks: a sixth of the largest object
FLANK_RADIUS_M = LARGEST_OBJECT_M / 6
