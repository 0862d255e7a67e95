"""The streaming engine's settings: :class:`EngineConfig` (stored in a live log, so its replay matches) and the
reconstruction settings the pipeline runs with (:func:`default_recon_config`)."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from recon.cluster import ClusterConfig
from recon.highlight import HighlightConfig
from recon.pipeline import ReconConfig


def default_recon_config() -> ReconConfig:
    """The pipeline's reconstruction settings, chosen on simulated missions (see benchmarks/RESULTS.md).

    Highlight threshold median + 4 MADs (the simulator's log-compressed frames: speckle up to ~85 grey
    levels, objects 140-190; the k = 8 default of recon missed the box). Front-slope correction on
    (arc re-placement): mean point-to-mesh distance 0.18 -> 0.03 m on the demo scene with true
    navigation. DBSCAN eps 0.5 m keeps each reef, whose frames and openings leave gaps of 0.3-0.5 m,
    in one cluster.
    """
    return ReconConfig(highlight=HighlightConfig(k=4.0), front_slope=True,
                       cluster=ClusterConfig(eps=0.5))


@dataclass(frozen=True)
class EngineConfig:
    """Settings that decide the results (stored in a live log, so its replay matches)."""

    frame_block: int = 1  # sonar frames per reconstruction call (live: 1 for latency)
    poll_s: float = 1.0  # mission seconds between streaming-clustering polls
    max_extrapolation_s: float = 1.0  # a frame this far past the last navigation sample is skipped
    max_pitch_deg: float = 15.0  # frames while the vehicle pitches more (diving, climbing) are skipped
    max_turn_rate_deg_s: float = 6.0  # frames while the vehicle turns faster (line ends) are skipped

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> EngineConfig:
        names = set(cls.__dataclass_fields__)
        return cls(**{k: v for k, v in d.items() if k in names})
