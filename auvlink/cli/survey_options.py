"""Ranges of the options that start simulated surveys (``eval --surveys``, ``train --calibrate-surveys``).

Checked before any work, so a typo (``--surveys 1000000000``, ``--workers -3``, ``--seed -1``) is one
line naming the option instead of a traceback or hours of work.
"""

from __future__ import annotations

from auvlink.errors import AuvlinkError

#: most surveys one run takes: each is minutes of simulation and replay, 10,000 already weeks of CPU
MAX_SURVEYS = 10_000
#: most worker processes: 16 x the 16-core machines the benchmarks ran on (each worker holds a mission)
MAX_WORKERS = 256
#: seeds as a scene's (auvlink.sim.scene.SceneFile.seed): what numpy's SeedSequence takes, in 63 bits
MAX_SEED = 2**63 - 1


def check_survey_options(surveys: tuple[str, int | None], seed: tuple[str, int | None], workers: int) -> None:
    """Refuse a survey count, seed or worker count out of range: ``(option name, value)`` pairs, ``--workers``."""
    for option, value, lo, hi in ((surveys[0], surveys[1], 1, MAX_SURVEYS), (seed[0], seed[1], 0, MAX_SEED),
                                  ("--workers", workers, 1, MAX_WORKERS)):
        if value is not None and not lo <= value <= hi:
            raise AuvlinkError(f"{option} must be an integer in [{lo}, {hi}], got {value}")
