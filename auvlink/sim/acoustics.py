"""The scene's ``[acoustics]`` table: which acoustic model renders the sonar image, and its parameters.

``profile`` names a parameter set; every other key overrides one value of it. The default, when the table
is absent or names no ``profile``, is the realistic profile of the scene's sonar model
(:func:`rendered_table`: :attr:`auvlink.sonar.SonarDescription.acoustic_profile`, the DIDSON's when the scene
names no model). The realistic profiles (``didson``, ``aris1800``, ``aris3000``, ``oculus-m750d``,
``oculus-m1200d``: each sonar model's own) are rendered by :mod:`auvlink.sim.acoustic_image`; a profile's
values are those of the frequency mode the scene's sonar flies (:data:`MODE_VALUES`: the Oculus'
low-frequency mode differs). ``profile = "ideal"`` names the idealized model of :mod:`auvlink.sim.speckle`
(K rays per beam with a hard vertical edge, one azimuth per beam, no pulse, fixed gain); it takes no
overrides. The physics of each key and its unit (docs/ACOUSTICS.md):

- vertical beam pattern (two-way power against elevation): ``vertical_pattern`` (``uniform`` hard
  edge, ``gaussian``, ``sinc2`` = the sinc^2 of a uniformly weighted aperture, first sidelobe
  -13.3 dB), ``vertical_width_deg`` (its -3 dB full width; the scene's ``sonar.spread_deg`` stays what recon assumes),
  ``vertical_extent`` (elevations integrated, in multiples of that width: the energy beyond the edge);
  ``elevation_samples`` per beam over that extent (the image integrates between them: no comb).
- azimuth beam pattern: ``azimuth_width_beams`` (two-way -3 dB width in beam spacings),
  ``sidelobe_db`` (two-way sidelobe level two beams off the main lobe; the envelope falls as ``1/k^2``
  with the offset ``k`` in beams, across the whole fan).
- ``pulse_m``: the transmitted pulse's range extent ``c tau / 2`` (m); an echo smears over
  ``[r, r + pulse_m]``.
- backscatter: ``seabed_backscatter_db`` (Lambert's ``mu``: ``sigma = mu sin^2(grazing)``),
  ``object_backscatter_db`` (added to an object's diffuse strength: ``mu`` times its material's
  reflection over the seabed's, the contrast of the ideal model),
  ``object_specular_db`` and ``specular_width_deg`` (a specular lobe of that peak and half-power
  half width around normal incidence).
- propagation and gain: ``absorption_db_per_m`` (one-way; spreading is spherical, two-way),
  ``tvg_error_db_per_m`` (the time-varied gain's error per metre from the window's middle),
  ``gain_db`` (the survey's gain offset) and ``gain_jitter_db`` (a further offset drawn once per
  survey, uniform in +-jitter, from the scene's seed).
- image statistics: ``speckle_looks`` (gamma shape of the speckle intensity; 1 = Rayleigh
  amplitude), ``texture_shape`` (K-distribution texture shape; 0 = none), ``noise_floor_db`` (mean
  additive noise, display dB), ``interference_fraction`` of frames with a bright band of
  ``interference_db`` (display dB) across the fan, ``display_floor_db`` / ``display_range_db`` (the
  8-bit log display: 0 at the floor, 255 at floor + range).
- surface multipath: ``multipath_db`` (the level of an echo's ghost over the sea surface against the
  echo itself: the surface's reflection loss plus the vertical pattern's far sidelobe towards the surface, both
  mixed paths together; ``-80`` or less turns it off). A ghost shows at the mixed paths' range
  ``(r + r_s) / 2`` (``r_s`` the path over the surface), no nearer than the hit's depth: only water shallower
  than the range window's far end shows ghosts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Annotated, Any, Literal

from pydantic import Field
from pydantic.dataclasses import dataclass as model

from auvlink.errors import ConfigError
from auvlink.sonar import Sonar, describe
from auvlink.validation import CONFIG, Integer, Number

ProfileName = Literal["ideal", "didson", "aris1800", "aris3000", "oculus-m750d", "oculus-m1200d"]
PatternShape = Literal["uniform", "gaussian", "sinc2"]
PROFILES: tuple[ProfileName, ...] = ("ideal", "didson", "aris1800", "aris3000", "oculus-m750d", "oculus-m1200d")


@dataclass(frozen=True)
class Acoustics:
    """A realistic acoustic model's parameters, resolved (profile values, then the scene's overrides)."""

    vertical_pattern: str
    vertical_width_deg: float
    vertical_extent: float
    elevation_samples: int
    azimuth_width_beams: float
    sidelobe_db: float
    pulse_m: float
    seabed_backscatter_db: float
    object_backscatter_db: float
    object_specular_db: float
    specular_width_deg: float
    absorption_db_per_m: float
    tvg_error_db_per_m: float
    gain_db: float
    gain_jitter_db: float
    speckle_looks: float
    texture_shape: float
    noise_floor_db: float
    interference_fraction: float
    interference_db: float
    display_floor_db: float
    display_range_db: float
    multipath_db: float


#: values every realistic profile shares unless it says otherwise
_COMMON: dict[str, Any] = {
    "vertical_extent": 3.0,  # +-1.5 widths, tapered over the outer 30 %: gaussian -27 dB at 1.05 widths
    "elevation_samples": 64,  # 0.67 deg apart over 42 deg; the image integrates between them (bench_sim)
    "object_backscatter_db": 0.0,  # the catalogue materials' contrast alone (auvlink.sim.object_meshes)
    "object_specular_db": 10.0,  # smooth manufactured faces: a glint 10 dB over diffuse (assumption)
    "specular_width_deg": 8.0,  # specular lobe half width of a face rough on the mm scale (assumption)
    "seabed_backscatter_db": -27.0,  # Lambert mu, the classic -27 dB (Mackenzie 1961), sand-like
    "tvg_error_db_per_m": 0.0,  # the sonar's TVG law matches the model's spreading and absorption
    "gain_db": 0.0,
    "texture_shape": 0.0,  # Rayleigh speckle on a homogeneous sand seabed
    "noise_floor_db": -58.0,  # display dB at mid-window: far range noise ~ the far seabed (ARIS sample darkens far)
    "interference_fraction": 0.0,  # interference belongs to the vehicle (its DVL), not the sonar
    "interference_db": -10.0,
    "display_floor_db": -60.0,  # 8-bit log display over 60 dB (DIDSON/ARIS viewers' default span)
    "display_range_db": 60.0,
    # a lens's vertical pattern ~30 dB down one way far off its axis (towards the surface, 60-90 deg above a fan
    # tilted down; assumption) plus ~3 dB of surface reflection loss, +3 dB for the two mixed paths
    "multipath_db": -30.0,
}

#: what the Oculus data sheets leave out, shared by both models and modes (issue 36's documented ranges)
_OCULUS: dict[str, Any] = {
    "vertical_pattern": "sinc2",  # shape not on the data sheet: a flat array's uniformly weighted element height
    "sidelobe_db": -20.0,  # not on the data sheet: receive-only beamforming under a wide transmit fan (one-way
    # sidelobes, not a lens' two-way): the harsher half of issue 36's -15 to -35 dB, 5 dB above the DIDSON's
    "gain_jitter_db": 3.0,  # as DIDSON (the operator's gain setting, in % on the Oculus)
    "speckle_looks": 2.0,  # not on the data sheet: as the ARIS sample's grey-level spread (same log display)
    "multipath_db": -25.0,  # a flat array's element pattern ~25 dB down one way towards the surface (assumption)
}


def _width_in_beams(model: str, mode: str) -> float:
    """The data sheet's angular resolution (deg) in beam spacings at the boresight: a sine-law table's spacing
    widens off the boresight as a phased array's beams do, so one width in spacings holds across the fan."""
    d = describe(model, mode)
    spacing = math.degrees(2.0 * math.sin(math.radians(d.half_fov_deg)) / (d.n_beams - 1))
    return d.beam_width_deg / spacing


#: the realistic profiles; each value's source in its comment
PROFILE_VALUES: dict[str, dict[str, Any]] = {
    "didson": {  # Sound Metrics DIDSON 300 m data sheet, identification mode (1.8 MHz, 96 beams)
        **_COMMON,
        "vertical_pattern": "gaussian",  # shape not on the data sheet: smooth main lobe (issue 36's model)
        "vertical_width_deg": 14.0,  # data sheet: 14 deg vertical beam width
        "azimuth_width_beams": 1.0,  # data sheet: 0.3 deg beam width, beams 0.3 deg apart
        "sidelobe_db": -25.0,  # lens sidelobes not on the data sheet: issue 36's DIDSON-like -25 dB
        "pulse_m": 0.04,  # 2 bins of a 10 m / 512 window (issue 36's DIDSON-like 2-bin pulse)
        "absorption_db_per_m": 0.9,  # Francois-Garrison pure-water term, 1.8 MHz, 10 degC
        "gain_jitter_db": 3.0,  # operator gain varies +-3 dB between surveys (issue 36's DIDSON-like)
        "speckle_looks": 2.0,  # local grey-level spread of the ARIS sample frames (tests/test_sim_acoustics)
    },
    "aris1800": {  # Sound Metrics ARIS Explorer 1800 data sheet, high-frequency mode (1.8 MHz, 96 beams)
        **_COMMON,
        "vertical_pattern": "sinc2",  # uniformly weighted lens aperture (shape not on the data sheet)
        "vertical_width_deg": 14.0,  # data sheet: 14 deg vertical beam width
        "azimuth_width_beams": 1.0,  # data sheet: 0.3 deg beam width, beams 0.3 deg apart
        "sidelobe_db": -30.0,  # not on the data sheet: assumed 5 dB below DIDSON's lens
        "pulse_m": 0.009,  # the ARIS sample capture's header: PulseWidth 12 us at 1436 m/s (c tau / 2)
        "absorption_db_per_m": 0.9,  # Francois-Garrison pure-water term, 1.8 MHz, 10 degC
        "gain_jitter_db": 3.0,  # as DIDSON (same operator gain control)
        "speckle_looks": 2.0,  # local grey-level spread of the ARIS sample frames (tests/test_sim_acoustics)
    },
    "aris3000": {  # Sound Metrics ARIS Explorer 3000 data sheet, high-frequency mode (3.0 MHz, 128 beams)
        **_COMMON,
        "vertical_pattern": "sinc2",  # uniformly weighted lens aperture (shape not on the data sheet)
        "vertical_width_deg": 14.0,  # data sheet: 14 deg vertical beam width (ONC's ARIS 3000 page too)
        "azimuth_width_beams": 0.8,  # data sheet: 0.25 deg beam width, in our 0.3 deg beam spacings
        "sidelobe_db": -30.0,  # not on the data sheet: assumed as ARIS 1800
        "pulse_m": 0.006,  # assumed 8 us at 3 MHz (the sample's 12 us scaled by the frequency ratio)
        "absorption_db_per_m": 2.6,  # Francois-Garrison pure-water term, 3.0 MHz, 10 degC
        "gain_jitter_db": 3.0,  # as DIDSON (same operator gain control)
        "speckle_looks": 2.0,  # local grey-level spread of the ARIS sample frames (tests/test_sim_acoustics)
    },
    "oculus-m750d": {  # Blueprint Subsea Oculus M750d data sheet, high-frequency mode (1.2 MHz, 512 beams over 70 deg)
        **_COMMON,
        **_OCULUS,
        "vertical_width_deg": 12.0,  # data sheet: 12 deg vertical aperture
        "azimuth_width_beams": round(_width_in_beams("oculus-m750d", "high"), 2),  # data sheet: 0.6 deg resolution
        "pulse_m": 0.0025,  # data sheet: 2.5 mm range resolution, taken as c tau / 2
        "absorption_db_per_m": 0.4,  # Francois-Garrison pure-water term, 1.2 MHz, 10 degC (0.9 x (1.2 / 1.8)^2)
    },
    "oculus-m1200d": {  # Blueprint Subsea Oculus M1200d data sheet, high-frequency mode (2.1 MHz, 512 beams, 60 deg)
        **_COMMON,
        **_OCULUS,
        "vertical_width_deg": 12.0,  # data sheet: 12 deg vertical aperture
        "azimuth_width_beams": round(_width_in_beams("oculus-m1200d", "high"), 2),  # data sheet: 0.4 deg resolution
        "pulse_m": 0.0025,  # data sheet: 2.5 mm range resolution, taken as c tau / 2
        "absorption_db_per_m": 1.2,  # Francois-Garrison pure-water term, 2.1 MHz, 10 degC (0.9 x (2.1 / 1.8)^2)
    },
}

#: (profile, frequency mode) -> the values that differ in that mode (the profiles above are the high mode's; the
#: DIDSON's and ARIS' low modes keep the vertical width, and their beam width is one beam spacing in either mode)
MODE_VALUES: dict[tuple[str, str], dict[str, Any]] = {
    ("oculus-m750d", "low"): {  # data sheet, low-frequency mode: 750 kHz, 130 x 20 deg, 1 deg, 4 mm
        "vertical_width_deg": 20.0,
        "azimuth_width_beams": round(_width_in_beams("oculus-m750d", "low"), 2),
        "pulse_m": 0.004,
        "absorption_db_per_m": 0.16,  # pure-water term at 750 kHz (0.9 x (0.75 / 1.8)^2)
    },
    ("oculus-m1200d", "low"): {  # data sheet, low-frequency mode: 1.2 MHz, 130 x 20 deg, 0.6 deg, 2.5 mm
        "vertical_width_deg": 20.0,
        "azimuth_width_beams": round(_width_in_beams("oculus-m1200d", "low"), 2),
        "pulse_m": 0.0025,
        "absorption_db_per_m": 0.4,  # pure-water term at 1.2 MHz (as the M750d's high mode)
    },
}

Db = Annotated[Number, Field(ge=-100.0, le=50.0, description="dB")]


@model(frozen=True, config=CONFIG)
class AcousticsTable:
    """``[acoustics]`` as written: a profile (absent: the sonar model's own realistic one) and value overrides."""

    profile: Annotated[ProfileName | None, Field(
        description="named parameter set; absent: the realistic profile of the scene's sonar model "
                    "(sonar.model, DIDSON if unset); ideal = the idealized model")] = None
    vertical_pattern: Annotated[PatternShape | None, Field(description="two-way vertical beam pattern shape")] = None
    vertical_width_deg: Annotated[Number | None, Field(gt=0.0, le=60.0, description="-3 dB full width, deg")] = None
    vertical_extent: Annotated[Number | None, Field(ge=1.0, le=4.0, description="integrated, x width")] = None
    elevation_samples: Annotated[Integer | None, Field(ge=8, le=256, description="per beam")] = None
    azimuth_width_beams: Annotated[Number | None, Field(gt=0.0, le=8.0, description="-3 dB, beams")] = None
    sidelobe_db: Annotated[Number | None, Field(ge=-80.0, le=-5.0, description="two-way, dB re main lobe")] = None
    pulse_m: Annotated[Number | None, Field(ge=0.0, le=1.0, description="range extent c tau / 2, m")] = None
    seabed_backscatter_db: Annotated[Number | None, Field(ge=-60.0, le=0.0, description="Lambert mu, dB")] = None
    object_backscatter_db: Annotated[Number | None, Field(ge=-40.0, le=20.0, description="dB")] = None
    object_specular_db: Annotated[Number | None, Field(ge=-40.0, le=40.0, description="dB over diffuse")] = None
    specular_width_deg: Annotated[Number | None, Field(gt=0.0, le=45.0, description="half width, deg")] = None
    absorption_db_per_m: Annotated[Number | None, Field(ge=0.0, le=20.0, description="one-way, dB/m")] = None
    tvg_error_db_per_m: Annotated[Number | None, Field(ge=-10.0, le=10.0, description="dB/m")] = None
    gain_db: Annotated[Number | None, Field(ge=-40.0, le=40.0, description="survey gain offset, dB")] = None
    gain_jitter_db: Annotated[Number | None, Field(ge=0.0, le=20.0, description="+- dB per survey")] = None
    speckle_looks: Annotated[Number | None, Field(ge=0.5, le=64.0, description="gamma shape")] = None
    texture_shape: Annotated[Number | None, Field(ge=0.0, le=100.0, description="K shape, 0 = none")] = None
    noise_floor_db: Db | None = None
    interference_fraction: Annotated[Number | None, Field(ge=0.0, le=1.0, description="of frames")] = None
    interference_db: Db | None = None
    display_floor_db: Db | None = None
    display_range_db: Annotated[Number | None, Field(ge=10.0, le=120.0, description="dB")] = None
    multipath_db: Annotated[Number | None, Field(ge=-100.0, le=0.0, description="surface ghost, dB re echo")] = None


def profile_named(name: str) -> ProfileName:
    """``name`` as one of :data:`PROFILES`; ``ValueError`` naming them for another."""
    for p in PROFILES:
        if p == name:
            return p
    raise ValueError(f"acoustic profile {name!r}: use one of {', '.join(PROFILES)}")


def rendered_table(table: AcousticsTable | None, sonar: Sonar) -> AcousticsTable:
    """The ``[acoustics]`` table a scene with ``sonar`` is rendered under: ``table`` when it names a profile;
    without a table, or with one that names no profile, the sonar model's own realistic profile (its data
    sheet's, :attr:`auvlink.sonar.SonarDescription.acoustic_profile`) with the table's overrides."""
    if table is not None and table.profile is not None:
        return table
    own = profile_named(sonar.description.acoustic_profile)
    return AcousticsTable(profile=own) if table is None else replace(table, profile=own)


def resolve(table: AcousticsTable, frequency_mode: str = "high") -> Acoustics | None:
    """The realistic model's parameters for a table that names its profile (:func:`rendered_table` gives a
    scene's), in the sonar's ``frequency_mode`` (:data:`MODE_VALUES`); ``None`` for the ``ideal`` profile.

    The rendered vertical width is the profile's (data sheet) unless the table sets one; the scene's
    ``sonar.spread_deg`` stays what the reconstruction assumes. ``ValueError`` for a table without a profile;
    :class:`~auvlink.errors.ConfigError` naming the key for the ``ideal`` profile with an override.
    """
    if table.profile is None:
        raise ValueError("the acoustics table names no profile: rendered_table(table, sonar) gives the scene's")
    if table.profile == "ideal":
        given = [f.name for f in fields(table) if f.name != "profile" and getattr(table, f.name) is not None]
        if given:
            raise ConfigError(f"acoustics.{given[0]}", "the ideal profile takes no overrides",
                              f"set acoustics.profile to one of {', '.join(PROFILES[1:])} or remove the key")
        return None
    values = {**PROFILE_VALUES[table.profile], **MODE_VALUES.get((table.profile, frequency_mode), {})}
    values.update({f.name: getattr(table, f.name) for f in fields(table)
                   if f.name != "profile" and getattr(table, f.name) is not None})
    return Acoustics(**values)
