"""Acoustic conditions drawn with each random survey (``auvlink eval --surveys N --acoustics SPACE``).

``SPACE`` is ``ideal`` (the idealized model: the scene of :mod:`auvlink.evaluation.draw` with
``[acoustics] profile = "ideal"``), a sonar profile name (``didson``, ``aris1800``, ``aris3000``,
``oculus-m750d``, ``oculus-m1200d``: that profile's values as they are, for surveys flown with its own
sonar model only: :func:`check_pairing` refuses another), or ``random``: the realistic profile of the
survey's sonar model (:func:`profile_of`) with every value below drawn uniformly in its range and
written over it (:data:`ACOUSTIC_SPACE`):

- ``vertical_pattern`` (uniform hard edge, gaussian, sinc^2) and ``vertical_extent`` (elevations
  integrated in multiples of the -3 dB width: the energy beyond the nominal edge);
- ``sidelobe_db`` -35 to -15 dB; a pulse of 1-4 range bins (``pulse_m`` = bins x window / 512);
- ``gain_db`` +-10 dB (the profile's jitter set to 0, so the drawn offset is the survey's);
- ``tvg_error_db_per_m``, ``noise_floor_db`` and ``interference_fraction``;
- ``multipath_db`` -40 to -20 dB (surface ghosts; drawn last, so the factors before it keep their values).

The draw of survey ``i`` comes from its own generator, seeded ``(seed, i, ACOUSTIC_STREAM)``: the survey
draw (its generator seeded ``(seed, i, 0x5A17E7)``) is the same under every ``SPACE``, and the same seed gives
the same acoustics. The stream still draws the profile index it once drew (:data:`FORMER_PROFILE_CHOICES`) and
ignores it, so every factor of a seed draws the values it drew when the profile was drawn apart from the
model. Units and physics of each key: docs/ACOUSTICS.md.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from auvlink.evaluation.survey_scores import pool
from auvlink.sim.acoustics import PROFILES
from auvlink.sim.scene import SIMULATED_MODELS
from auvlink.sim.sonar_geometry import N_BINS
from auvlink.sonar import describe

#: the SeedSequence entropy word of the acoustic stream (any value other than the survey draw's 0x5A17E7)
ACOUSTIC_STREAM = 0xAC0571C
#: realistic profiles a random draw starts from (every supported sonar's; the idealized model is none)
SONAR_PROFILES: tuple[str, ...] = tuple(p for p in PROFILES if p != "ideal")
#: how many profiles the stream's first draw chose among before the profile followed the sonar model (didson,
#: aris1800, aris3000): still drawn, and ignored, so the factors after it keep their values for a seed
FORMER_PROFILE_CHOICES = 3
SPACES: tuple[str, ...] = ("random", *PROFILES)
PATTERNS: tuple[str, ...] = ("uniform", "gaussian", "sinc2")  # auvlink.sim.acoustics.PatternShape

#: numeric acoustic factors: name -> (low, high), uniform; each range's source in its comment
ACOUSTIC_SPACE: dict[str, tuple[float, float]] = {
    "vertical_extent": (1.0, 4.0),  # the scene schema's range: no energy beyond the edge to +-2 widths
    "sidelobe_db": (-35.0, -15.0),  # issue 36: sidelobe level -15 to -35 dB
    "pulse_bins": (1.0, 4.0),  # issue 36: pulse 1-4 range bins
    "gain_db": (-10.0, 10.0),  # issue 36: survey gain offset +-10 dB
    "tvg_error_db_per_m": (-2.0, 2.0),  # the ARIS sample's fall along range needs -2 dB/m (docs/ACOUSTICS.md)
    "noise_floor_db": (-60.0, -45.0),  # display floor (invisible) to ~13 dB under a level -32 dB sand seabed
    "interference_fraction": (0.0, 0.05),  # issue 36's harsh case has stripes in 2 % of frames
    # surface ghosts: a lens's far vertical sidelobe (-30 dB one way) to an array element's (-20 dB) plus 0-10 dB of
    # surface loss (calm to choppy at 1-3 MHz; assumption); drawn last, so the factors above keep their values
    "multipath_db": (-40.0, -20.0),
}

#: factor -> bin edges (numeric) or categories; the rows of the per-factor table
ACOUSTIC_BINS: dict[str, tuple[float, ...] | tuple[str, ...]] = {
    "profile": SONAR_PROFILES,
    "vertical_pattern": PATTERNS,
    "vertical_extent": (1.0, 2.0, 3.0, 4.0),
    "sidelobe_db": (-35.0, -28.0, -22.0, -15.0),
    "pulse_bins": (1.0, 2.0, 3.0, 4.0),
    "gain_db": (-10.0, -3.0, 3.0, 10.0),
    "tvg_error_db_per_m": (-2.0, -0.7, 0.7, 2.0),
    "noise_floor_db": (-60.0, -55.0, -50.0, -45.0),
    "interference_fraction": (0.0, 0.01, 0.03, 0.05),
    "multipath_db": (-40.0, -33.0, -27.0, -20.0),
}


@dataclass(frozen=True)
class AcousticDraw:
    """One survey's acoustic conditions: the profile and the values drawn over it (None: the profile's)."""

    profile: str
    vertical_pattern: str | None = None
    vertical_extent: float | None = None
    sidelobe_db: float | None = None
    pulse_bins: float | None = None
    pulse_m: float | None = None  # pulse_bins x the survey's range bin (window_length / 512), m
    gain_db: float | None = None
    gain_jitter_db: float | None = None
    tvg_error_db_per_m: float | None = None
    noise_floor_db: float | None = None
    interference_fraction: float | None = None
    multipath_db: float | None = None

    def to_dict(self) -> dict[str, object]:
        return asdict(self)

    def overrides(self) -> dict[str, str | float]:
        """The ``[acoustics]`` keys this draw sets over its profile (``pulse_bins`` is written as ``pulse_m``)."""
        return {k: v for k, v in asdict(self).items() if v is not None and k not in ("profile", "pulse_bins")}

    def table_toml(self) -> str:
        """The scene's ``[acoustics]`` table: the profile, named for every draw (``ideal`` too: a scene without the
        table renders under its sonar model's realistic profile), and the overrides."""
        rows = ["[acoustics]", f'profile = "{self.profile}"']
        rows += [f'{k} = "{v}"' if isinstance(v, str) else f"{k} = {v!r}" for k, v in self.overrides().items()]
        return "\n".join(rows) + "\n"

    def factors(self) -> dict[str, str | float]:
        """The acoustic factors the results are binned by: those drawn (none for ``ideal``)."""
        if self.profile == "ideal":
            return {}
        return {k: v for k, v in asdict(self).items() if k in ACOUSTIC_BINS and v is not None}


#: the idealized model: ``[acoustics] profile = "ideal"``, no overrides
IDEAL = AcousticDraw(profile="ideal")


def profile_of(model: str) -> str:
    """The realistic acoustic profile of a sonar model: its data sheet's (:data:`auvlink.sonar.DATA_SHEETS`)."""
    return describe(model).acoustic_profile


def models_of(profile: str) -> tuple[str, ...]:
    """The simulated sonar models whose realistic profile is ``profile`` (none for ``ideal``)."""
    return tuple(m for m in SIMULATED_MODELS if profile_of(m) == profile)


def check_pairing(space: str, sonar: str) -> None:
    """Refuse a fixed profile ``space`` for surveys flown with ``sonar`` (a model or ``random``) it does not
    describe: ``ValueError`` naming both options and the fix. ``ideal`` and ``random`` pair with any model."""
    if space in ("ideal", "random"):
        return
    if space not in SPACES:
        raise ValueError(f"acoustic space {space!r}: expected one of {', '.join(SPACES)}")
    own = models_of(space)
    if sonar not in own:
        flown = "a model drawn per survey" if sonar == "random" else f"the {sonar}"
        raise ValueError(f"--acoustics {space} is the profile of {' / '.join(own)} but --sonar {sonar} flies {flown}: "
                         f"use --acoustics random (each survey its own model's profile) or ideal, "
                         f"or --sonar {own[0]}")


def draw_acoustics(space: str, seed: int, index: int, window_length: float, model: str = "didson") -> AcousticDraw:
    """Survey ``index``'s acoustics in ``space`` (module docstring) for a range window ``window_length`` m long,
    the survey flown with the sonar ``model`` (whose profile a ``random`` draw starts from)."""
    if space not in SPACES:
        raise ValueError(f"acoustic space {space!r}: expected one of {', '.join(SPACES)}")
    if space == "ideal":
        return IDEAL
    check_pairing(space, model)
    if space != "random":
        return AcousticDraw(profile=space)
    rng = np.random.default_rng(np.random.SeedSequence([seed, index, ACOUSTIC_STREAM]))
    rng.integers(FORMER_PROFILE_CHOICES)  # the former profile draw, ignored: the later factors keep their values
    profile = profile_of(model)
    pattern = PATTERNS[int(rng.integers(len(PATTERNS)))]
    v = {name: float(rng.uniform(lo, hi)) for name, (lo, hi) in ACOUSTIC_SPACE.items()}
    bin_m = window_length / N_BINS
    return AcousticDraw(profile=profile, vertical_pattern=pattern, vertical_extent=round(v["vertical_extent"], 3),
                        sidelobe_db=round(v["sidelobe_db"], 2), pulse_bins=round(v["pulse_bins"], 3),
                        pulse_m=round(v["pulse_bins"] * bin_m, 5), gain_db=round(v["gain_db"], 2), gain_jitter_db=0.0,
                        tvg_error_db_per_m=round(v["tvg_error_db_per_m"], 3),
                        noise_floor_db=round(v["noise_floor_db"], 2),
                        interference_fraction=round(v["interference_fraction"], 4),
                        multipath_db=round(v["multipath_db"], 2))


def acoustic_bin(factor: str, value: str | float) -> str:
    """The label of the bin of :data:`ACOUSTIC_BINS` that ``value`` falls in (edges[i] <= v < edges[i + 1],
    the last bin closed; a category is its own label)."""
    edges = ACOUSTIC_BINS[factor]
    if isinstance(value, str):
        return value
    num = np.asarray(edges, dtype=float)
    i = int(np.clip(np.searchsorted(num, value, side="right") - 1, 0, len(num) - 2))
    return f"{num[i]:g}-{num[i + 1]:g}"


def _labels(factor: str) -> list[str]:
    edges = ACOUSTIC_BINS[factor]
    if isinstance(edges[0], str):
        return [str(e) for e in edges]
    return [f"{float(edges[k]):g}-{float(edges[k + 1]):g}" for k in range(len(edges) - 1)]


def by_acoustic_factor(scores: Sequence[dict[str, Any]], factors: Sequence[dict[str, str | float]]
                       ) -> dict[str, list[dict[str, Any]]]:
    """Per acoustic factor some survey has, per bin, the pooled scores of the surveys that fall in it."""
    out: dict[str, list[dict[str, Any]]] = {}
    for f in ACOUSTIC_BINS:
        if not any(f in fa for fa in factors):
            continue
        rows = []
        for label in _labels(f):
            sel = [s for s, fa in zip(scores, factors, strict=True) if f in fa and acoustic_bin(f, fa[f]) == label]
            rows.append({"factor": f, "bin": label, **pool(sel)})
        out[f] = rows
    return out
