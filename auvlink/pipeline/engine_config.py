"""The streaming engine's settings: :class:`EngineConfig` (stored in a live log, so its replay matches) and the
reconstruction settings the pipeline runs with (:func:`default_recon_config`)."""

from __future__ import annotations

from dataclasses import asdict
from typing import Annotated, Any

from pydantic import Field
from pydantic.dataclasses import dataclass

from auvlink.validation import CONFIG, Integer, Number, validate
from recon.cluster import ClusterConfig
from recon.highlight import HighlightConfig
from recon.reconstructor import ReconConfig


def default_recon_config() -> ReconConfig:
    """The pipeline's reconstruction settings (see benchmarks/RESULTS.md): the frame's water threshold at its median
    + 4 robust standard deviations (recon.highlight; with calibration the rows' thresholds follow the image's own
    statistics above it), the front-slope correction on (arc re-placement: mean point-to-mesh distance 0.18 -> 0.03 m
    on the demo scene with true navigation), DBSCAN eps 0.5 m (a reef's frames and openings leave gaps of 0.3-0.5 m:
    each reef stays one cluster).
    """
    return ReconConfig(highlight=HighlightConfig(k=4.0), front_slope=True,
                       cluster=ClusterConfig(eps=0.5))


@dataclass(frozen=True, config=CONFIG)
class EngineConfig:
    """Settings that decide the results (stored in a live log, so its replay matches; validated like the
    vehicle configuration, so a stored value out of range is refused by key)."""

    #: sonar frames per reconstruction call (live: 1 for latency); 4096 DIDSON frames (96 x 512 bytes each)
    #: are 200 MB held at once
    frame_block: Annotated[Integer, Field(ge=1, le=4096)] = 1
    #: mission seconds between streaming-clustering polls (at most one poll per reconstruction call); an hour
    #: between polls is already a mission's whole length
    poll_s: Annotated[Number, Field(gt=0.0, le=3600.0)] = 1.0
    #: a frame this far (s) past the last navigation sample is skipped; a minute of dead reckoning past the
    #: last sample is far beyond what the navigation can extrapolate
    max_extrapolation_s: Annotated[Number, Field(ge=0.0, le=60.0)] = 1.0
    #: frames while the vehicle pitches more (diving, climbing) are skipped; pitch is in [-90, 90] deg, and a
    #: limit <= 0 would skip every frame
    max_pitch_deg: Annotated[Number, Field(gt=0.0, le=90.0)] = 15.0
    #: frames while the vehicle turns faster (line ends) are skipped; a limit <= 0 would skip every frame, a
    #: very large one (1e9) switches the gate off
    max_turn_rate_deg_s: Annotated[Number, Field(gt=0.0)] = 6.0

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> EngineConfig:
        """The settings of ``d`` (unknown keys ignored); :class:`~auvlink.errors.ConfigError` naming a bad key."""
        names = set(cls.__dataclass_fields__)
        return validate(cls, {k: v for k, v in d.items() if k in names})
