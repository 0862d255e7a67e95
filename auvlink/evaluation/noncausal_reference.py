"""The non-causal batch reference of the pipeline (tests): a whole mission log dead-reckoned at once,
reconstructed in blocks and clustered at the end. The product path is the streaming engine
(:func:`auvlink.pipeline.process.run_log`); this one checks it."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from auvlink.errors import AuvlinkError
from auvlink.pipeline.collect import MissionData
from auvlink.pipeline.engine_config import default_recon_config
from auvlink.pipeline.nav_inputs import CONSUMED_FORMATS
from auvlink.pipeline.process import FRAME_BLOCK
from auvlink.pipeline.setup import MissionSetup, nav_config, sonar_geometry
from logs_format import MissionLogReader, Replay
from recon.cluster import DetectedObject
from recon.nav import dead_reckon
from recon.reconstructor import ReconConfig, Reconstructor
from recon.trajectory import Trajectory


def run_log_batch(log: Path, *, recon_config: ReconConfig | None = None) -> tuple[list[DetectedObject], Trajectory]:
    """Reference for tests: the whole mission dead-reckoned at once (non-causal), reconstructed in
    blocks and clustered at the end; returns (objects, trajectory). No classification."""
    with MissionLogReader(log) as reader:
        setup = MissionSetup.from_metadata(reader.metadata(decode_json=True))
    data = MissionData()
    with Replay(log, formats=CONSUMED_FORMATS) as replay:
        for sample in replay.samples():
            data.add(sample)
    if data.n("dvl") < 2 or data.n("gyro") < 2 or not data.n("depth"):
        raise AuvlinkError(f"{log}: not enough navigation to process")
    traj = dead_reckon(*data.nav_inputs(), nav_config(setup))
    times, images = data.sonar.stack()
    geometry = sonar_geometry(setup, data.sonar.azimuths, data.sonar.window, n_bins=images.shape[1] or None)
    rec = Reconstructor(geometry, traj, recon_config or default_recon_config())
    lo, hi = traj.span
    idx = np.flatnonzero((times >= lo) & (times <= hi))
    for k in range(0, idx.size, FRAME_BLOCK):
        sel = idx[k : k + FRAME_BLOCK]
        rec.add_frames(times[sel], images[sel])
    return rec.finish(), traj
