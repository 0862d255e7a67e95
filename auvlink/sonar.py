"""The one description of the forward-scan sonar and of a device's mounting (core; no numpy).

:class:`Sonar` is the geometry every layer shares: the vehicle configuration's ``[sonar]`` table
(:class:`auvlink.config.VehicleSonar` adds which device it is), the scene's ``[sonar]`` table
(:class:`auvlink.sim.scene.SonarConfig` adds the frame rate, lever arm and rays per beam), the
pipeline's :class:`~auvlink.pipeline.setup.MissionSetup` and recon's
:class:`~recon.sonar_geometry.SonarGeometry` (built with ``SonarGeometry.of``). Degrees and metres
as a person writes them; :attr:`Sonar.tilt` and :attr:`Sonar.spread` give radians.

:class:`Mounting` places a device in the body frame B (FRD): lever arm ``xyz`` (m) and rotation
``rpy_deg`` (roll, pitch, yaw of the device in B, degrees, R_BX = Rz(yaw) Ry(pitch) Rx(roll)).

:class:`SonarDescription` is what the sonar *is*: its beam bearings as a table (deg in the sonar frame S,
+ to starboard, column 0 of an image the port-most beam), vertical aperture, range resolution or samples per
beam, frequency, beam width and the acoustic profile of :mod:`auvlink.sim.acoustics`. It is built from a
named model and frequency mode (:func:`describe`, the data sheets' table :data:`DATA_SHEETS`), from a
configuration's ``[sonar] model = "..."`` (:attr:`Sonar.description`, the vehicle configuration, a scene or a
log's stored configuration) or from a decoded frame's own header (:func:`describe_frame`). Every stage takes its
beam count and field of view from it.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass as plain_dataclass
from dataclasses import replace
from typing import Annotated, Literal

from pydantic import Field
from pydantic.dataclasses import dataclass

from auvlink.validation import CONFIG, Number, Vec3

#: the named sonars (data sheets in :mod:`auvlink.sonar_models`)
SonarModelName = Literal["didson", "aris1800", "aris3000", "oculus-m750d", "oculus-m1200d"]
#: a dual-frequency sonar's mode: ``high`` (identification: more, narrower beams) or ``low`` (detection, range)
FrequencyMode = Literal["high", "low"]
#: beam counts a description may hold: from the ARIS 1200's 48-beam mode (fewest of any imaging sonar's mode
#: in the table, 8 leaves room) to twice the Oculus' 512 beams
MIN_BEAMS, MAX_BEAMS = 8, 1024
#: widest horizontal field of view (deg): the Oculus M750d/M1200d low-frequency mode's 130 deg
MAX_APERTURE_DEG = 130.0
#: vertical apertures (deg) a description may hold: every data sheet of the table is 12-20 deg
MIN_VERTICAL_DEG, MAX_VERTICAL_DEG = 1.0, 60.0
#: most range lines of one image: the bound of the Oculus' image (auvlink.framing.oculus_defs.MAX_RANGES); a longer
#: window is sampled coarser than the data sheet's resolution
MAX_RANGE_LINES = 4096

#: largest range window start and length (m): far beyond any imaging sonar's reach
MAX_WINDOW_M = 200.0


@dataclass(frozen=True, kw_only=True, config=CONFIG)
class Sonar:
    """Geometry of the forward-scan sonar: tilt and vertical spread (deg), range window (m)."""

    tilt_deg: Annotated[Number, Field(gt=-90.0, lt=90.0, description="pitch down of the boresight, deg (+ looks down)")]
    spread_deg: Annotated[Number, Field(gt=0.0, lt=90.0, description="vertical beam spread, deg")] = 14.0
    window_start: Annotated[Number, Field(ge=0.0, le=MAX_WINDOW_M, description="start of the range window, m")]
    window_length: Annotated[Number, Field(gt=0.0, le=MAX_WINDOW_M, description="length of the range window, m")]
    model: Annotated[SonarModelName | None, Field(description="which sonar (data sheet); absent: didson")] = None
    frequency_mode: Annotated[FrequencyMode | None, Field(description="high or low frequency; absent: high")] = None

    @property
    def description(self) -> SonarDescription:
        """The named model's data-sheet description in the configured frequency mode (DIDSON, high, if unset)."""
        return describe(self.model or DEFAULT_MODEL, self.frequency_mode or "high")

    @property
    def tilt(self) -> float:
        """Tilt in radians."""
        return math.radians(self.tilt_deg)

    @property
    def spread(self) -> float:
        """Vertical spread in radians."""
        return math.radians(self.spread_deg)

    @property
    def window_end(self) -> float:
        return self.window_start + self.window_length

    def geometry(self) -> Sonar:
        """The shared geometry alone (drops what a subclass adds)."""
        return Sonar(tilt_deg=self.tilt_deg, spread_deg=self.spread_deg, window_start=self.window_start,
                     window_length=self.window_length, model=self.model, frequency_mode=self.frequency_mode)


@plain_dataclass(frozen=True)
class SonarDescription:
    """What a forward-scan sonar is: beams, apertures, range sampling, frequency (deg, m, Hz).

    ``bearings_deg`` holds the beam centres in the sonar frame S (+ to starboard), column 0 of an image the
    port-most beam, strictly increasing; a fixed-sample sonar (DIDSON, ARIS: ``samples`` per beam over the
    window) has no ``range_resolution_m``, an Oculus (range lines at its resolution) has no ``samples``.
    """

    model: str
    frequency_mode: str
    frequency_hz: float
    bearings_deg: tuple[float, ...]
    vertical_aperture_deg: float  # -3 dB vertical beam width, deg
    beam_width_deg: float  # -3 dB horizontal width of one beam, deg
    max_range_m: float
    acoustic_profile: str = "ideal"  # the profile name of auvlink.sim.acoustics
    samples: int | None = None  # range samples per beam over any window
    range_resolution_m: float | None = None  # range line spacing, m

    def __post_init__(self) -> None:
        b = self.bearings_deg
        if not MIN_BEAMS <= len(b) <= MAX_BEAMS:
            raise ValueError(f"sonar {self.model}: {len(b)} beams, expected {MIN_BEAMS}..{MAX_BEAMS}")
        if any(not math.isfinite(x) for x in b) or any(hi <= lo for lo, hi in itertools.pairwise(b)):
            raise ValueError(f"sonar {self.model}: bearings must be finite and strictly increasing (port first)")
        if b[-1] - b[0] > MAX_APERTURE_DEG or max(-b[0], b[-1]) > MAX_APERTURE_DEG / 2.0:
            raise ValueError(f"sonar {self.model}: bearings {b[0]}..{b[-1]} deg beyond +-{MAX_APERTURE_DEG / 2} deg")
        if not MIN_VERTICAL_DEG <= self.vertical_aperture_deg <= MAX_VERTICAL_DEG:
            raise ValueError(f"sonar {self.model}: vertical aperture {self.vertical_aperture_deg} deg, "
                             f"expected {MIN_VERTICAL_DEG}..{MAX_VERTICAL_DEG}")
        if (self.samples is None) == (self.range_resolution_m is None):
            raise ValueError(f"sonar {self.model}: give samples per beam or a range resolution, not both")

    @property
    def n_beams(self) -> int:
        return len(self.bearings_deg)

    @property
    def field_of_view_deg(self) -> float:
        """Span of the beam centres, deg (port-most to starboard-most)."""
        return self.bearings_deg[-1] - self.bearings_deg[0]

    @property
    def half_fov_deg(self) -> float:
        """Largest beam-centre bearing either side of the boresight, deg."""
        return max(-self.bearings_deg[0], self.bearings_deg[-1])

    @property
    def bearings_rad(self) -> tuple[float, ...]:
        return tuple(math.radians(x) for x in self.bearings_deg)

    @property
    def is_linear(self) -> bool:
        """Beams evenly spaced in bearing (within 1e-9 deg): a field of view and a count describe them."""
        return bearings_equal(self.bearings_deg, linear_bearings(self.bearings_deg[-1], self.n_beams,
                                                                 self.bearings_deg[0]), 1e-9)

    def range_lines(self, window_length_m: float) -> int:
        """Rows of an image over a window (m): the fixed samples, or the window over the range resolution."""
        if self.samples is not None:
            return self.samples
        assert self.range_resolution_m is not None
        return max(1, min(MAX_RANGE_LINES, round(window_length_m / self.range_resolution_m)))

    def image_window(self, start_m: float, length_m: float) -> tuple[float, float]:
        """The range window (start, length, m) of the images the sonar sends for a configured window: a fixed-sample
        sonar samples the window itself; an Oculus' range lines start at the transducer and reach the window's end."""
        return (start_m, length_m) if self.samples is not None else (0.0, start_m + length_m)

    def with_beams(self, n_beams: int) -> SonarDescription:
        """The same sonar sending ``n_beams`` over the same field (an Oculus sends 256 or 512), bearings re-drawn
        by the model's law (linear, or the Oculus' sine law)."""
        half = self.half_fov_deg
        oculus = self.model.startswith("oculus")
        table = arcsine_bearings(half, n_beams, wire=True) if oculus else linear_bearings(half, n_beams)
        return replace(self, bearings_deg=table)


def linear_bearings(half_deg: float, n: int, start_deg: float | None = None) -> tuple[float, ...]:
    """``n`` bearings (deg) evenly spaced from ``start_deg`` (default ``-half_deg``) to ``half_deg``, the values
    ``numpy.linspace`` gives (so a stage's linspace and the table agree bit for bit)."""
    lo = -half_deg if start_deg is None else start_deg
    step = (half_deg - lo) / (n - 1)
    return (*(lo + i * step for i in range(n - 1)), half_deg)


def arcsine_bearings(half_deg: float, n: int, wire: bool = False) -> tuple[float, ...]:
    """The Oculus' uneven table: beams evenly spaced in sin(bearing) over +-``half_deg`` (wider apart at the edges).
    ``wire``: as the sonar sends them, int16 hundredths of a degree cut toward zero (the real ping of
    ``shared/data/oculus`` holds exactly these 256 values)."""
    s = math.sin(math.radians(half_deg))
    exact = [math.degrees(math.asin(s * (2.0 * i / (n - 1) - 1.0))) for i in range(n)]
    if not wire:
        return tuple(exact)
    return tuple(math.trunc(100.0 * x + math.copysign(1e-6, x)) / 100.0 for x in exact)


def aris_bearings(beams: int) -> tuple[float, ...]:
    """The ARIS SDK beam table for ``beams`` (deg, port first; :func:`auvlink.framing.aris_defs.beam_tables`)."""
    from auvlink.framing.aris_defs import beam_table_name, beam_tables

    return tuple(-float(x) for x in beam_tables()[beam_table_name(beams)][::-1])


def bearings_equal(a: tuple[float, ...], b: tuple[float, ...], tol_deg: float) -> bool:
    return len(a) == len(b) and all(abs(x - y) <= tol_deg for x, y in zip(a, b, strict=True))


DEFAULT_MODEL: SonarModelName = "didson"
#: (model, frequency mode) -> frequency Hz, beams, half field deg, bearing law, vertical deg, beam width deg,
#: max range m, samples per beam or range resolution m, acoustic profile; one data sheet per line
DATA_SHEETS: dict[tuple[str, str], tuple[float, int, float, str, float, float, float, int | float, str]] = {
    # Sound Metrics DIDSON 300 m data sheet: identification 1.8 MHz, 96 beams of 0.3 deg over 29 deg, 14 deg vertical,
    # 512 samples per beam, 15 m; detection 1.1 MHz, 48 beams of 0.6 deg, 40 m (beam centres +-14.5 deg as
    # ARCHITECTURE.md's linear fallback)
    ("didson", "high"): (1.8e6, 96, 14.5, "linear", 14.0, 0.3, 15.0, 512, "didson"),
    ("didson", "low"): (1.1e6, 48, 14.5, "linear", 14.0, 0.6, 40.0, 512, "didson"),
    # Sound Metrics ARIS Explorer 1800 data sheet: 1.8 MHz 96 beams of 0.3 deg, 1.1 MHz 48 beams of 0.6 deg, 28 deg
    # field, 14 deg vertical, 15 m / 35 m; bearings from the ARIS SDK beam tables
    ("aris1800", "high"): (1.8e6, 96, 0.0, "aris", 14.0, 0.3, 15.0, 512, "aris1800"),
    ("aris1800", "low"): (1.1e6, 48, 0.0, "aris", 14.0, 0.6, 35.0, 512, "aris1800"),
    # Sound Metrics ARIS Explorer 3000 data sheet: 3.0 MHz 128 beams of 0.25 deg, 1.8 MHz 64 beams of 0.5 deg,
    # 30 deg field, 14 deg vertical, 5 m / 15 m
    ("aris3000", "high"): (3.0e6, 128, 0.0, "aris", 14.0, 0.25, 5.0, 512, "aris3000"),
    ("aris3000", "low"): (1.8e6, 64, 0.0, "aris", 14.0, 0.5, 15.0, 512, "aris3000"),
    # Blueprint Subsea Oculus M750d data sheet: 1.2 MHz 70 x 12 deg, 512 beams, 0.6 deg angular resolution,
    # 2.5 mm range resolution, 40 m; 750 kHz 130 x 20 deg, 512 beams, 1 deg, 4 mm, 120 m
    ("oculus-m750d", "high"): (1.2e6, 512, 35.0, "arcsine", 12.0, 0.6, 40.0, 0.0025, "oculus-m750d"),
    ("oculus-m750d", "low"): (750e3, 512, 65.0, "arcsine", 20.0, 1.0, 120.0, 0.004, "oculus-m750d"),
    # Blueprint Subsea Oculus M1200d data sheet: 2.1 MHz 60 x 12 deg, 512 beams, 0.4 deg, 2.5 mm, 10 m;
    # 1.2 MHz 130 x 20 deg, 512 beams, 0.6 deg, 2.5 mm, 30 m
    ("oculus-m1200d", "high"): (2.1e6, 512, 30.0, "arcsine", 12.0, 0.4, 10.0, 0.0025, "oculus-m1200d"),
    ("oculus-m1200d", "low"): (1.2e6, 512, 65.0, "arcsine", 20.0, 0.6, 30.0, 0.0025, "oculus-m1200d"),
}


def describe(model: str = DEFAULT_MODEL, frequency_mode: str = "high", n_beams: int | None = None) -> SonarDescription:
    """The data-sheet description of a named sonar in a frequency mode (``n_beams``: a mode sending fewer beams,
    such as an Oculus set to 256). Unknown names raise ``KeyError`` listing the known ones."""
    try:
        freq, beams, half, law, vertical, width, reach, sampling, profile = DATA_SHEETS[(model, frequency_mode)]
    except KeyError as exc:
        known = sorted({m for m, _ in DATA_SHEETS})
        raise KeyError(f"sonar model {model!r} / mode {frequency_mode!r}: use one of {', '.join(known)}, "
                       "mode high or low") from exc
    bearings = (aris_bearings(beams) if law == "aris" else arcsine_bearings(half, beams, wire=True) if law == "arcsine"
                else linear_bearings(half, beams))
    fixed = isinstance(sampling, int)
    d = SonarDescription(model=model, frequency_mode=frequency_mode, frequency_hz=freq, bearings_deg=bearings,
                         vertical_aperture_deg=vertical, beam_width_deg=width, max_range_m=reach,
                         acoustic_profile=profile, samples=int(sampling) if fixed else None,
                         range_resolution_m=None if fixed else float(sampling))
    return d if n_beams is None or n_beams == beams else d.with_beams(n_beams)


#: the description of :data:`DEFAULT_SONAR`: a DIDSON 300 m in its identification (high-frequency) mode
DIDSON = describe(DEFAULT_MODEL)


#: the DIDSON-class sonar of the architecture (tilt 30 deg, spread 14 deg, window 1 + 10 m)
DEFAULT_SONAR = Sonar(tilt_deg=30.0, spread_deg=14.0, window_start=1.0, window_length=10.0)

#: lever arms beyond this (m) are typing errors on any AUV
MAX_LEVER_M = 50.0
Lever = Annotated[Vec3, Field(description="lever arm in the body frame (FRD), m")]


@dataclass(frozen=True, config=CONFIG)
class Mounting:
    """Where a device sits on the vehicle: lever arm in the body frame (FRD, m) and its rotation (deg)."""

    xyz: Lever = (0.0, 0.0, 0.0)
    rpy_deg: Annotated[Vec3, Field(description="roll, pitch, yaw of the device in B, deg")] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if any(abs(v) > MAX_LEVER_M for v in self.xyz):
            raise ValueError(f"lever arm {list(self.xyz)} m beyond +-{MAX_LEVER_M} m")
        if any(abs(v) > 360.0 for v in self.rpy_deg):
            raise ValueError(f"rpy_deg {list(self.rpy_deg)} beyond +-360 deg")

    @property
    def rpy(self) -> tuple[float, float, float]:
        """Roll, pitch, yaw in radians."""
        r, p, y = (math.radians(v) for v in self.rpy_deg)
        return (r, p, y)
