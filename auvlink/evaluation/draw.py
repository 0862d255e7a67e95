"""Random surveys drawn from the condition space the pipeline must work in.

The space (every value uniform in its range unless said otherwise):

- seabed: depth 10-60 m, slope 0-10 deg towards any azimuth, roughness 0-0.10 m rms (the
  simulator's own texture model: sinusoids of wavelength 0.5-8 m, :mod:`auvlink.sim.seabed`);
- vehicle: altitude 3-7 m, speed 0.6-1.5 m/s, survey heading 0-360 deg, a water current up to
  0.1 m/s from any direction (the demo scene has 0.11 m/s);
- sonar: a model (:func:`survey_sonar`: the DIDSON unless asked; ``random``: one of
  :data:`auvlink.sim.scene.SIMULATED_MODELS` per survey, from its own stream so the other factors stay),
  its fan and vertical spread (:func:`auvlink.sonar.describe`), tilt 20-45 deg, 5-15 frames/s, the range
  window holding the seabed onset for any look direction over the slope, with room before it for a 2 m
  object's highlight extension;
- lawnmower: lines spaced at 40-80 % of the swath at the seabed onset (2 R sin of the half field, R
  the slant range of the onset), 3-5 lines, the line length set by the objects;
- objects: 5-8, any class of the catalogue, any heading, centres at least 6 m apart and inside the
  band every line's fan covers (across: between the outer lines' swath centres widened by a quarter
  swath; along: where both line directions look, the onset's horizontal reach inside both ends).

The survey starts at the NED origin (the geo-referencing issue lifts that). Every draw comes from a
:class:`numpy.random.Generator` seeded from ``(seed, index)``: the same seed gives the same scenes,
and survey ``i`` does not depend on how many surveys were drawn.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from auvlink.sim.scene import CLASSES, SIMULATED_MODELS
from auvlink.sonar import SonarModelName, describe

LEVER_ARM = (0.6, 0.0, 0.2)  # sonar head in the body frame (FRD, m), as in the shipped scene
MIN_SEPARATION = 6.0  # m between object centres
MAX_OBJECT_HEIGHT = 2.0  # m: the window starts early enough for this object's highlight extension

#: condition space: name -> (low, high)
SPACE: dict[str, tuple[float, float]] = {
    "depth": (10.0, 60.0), "slope_deg": (0.0, 10.0), "roughness": (0.0, 0.10), "altitude": (3.0, 7.0),
    "tilt_deg": (20.0, 45.0), "speed": (0.6, 1.5), "fps": (5.0, 15.0), "spacing_fraction": (0.4, 0.8),
    "current": (0.0, 0.1),
}


@dataclass(frozen=True)
class SurveyDraw:
    """One random survey: the factors (SI but angles in degrees, as in a scene file) and its objects."""

    index: int
    seed: int  # the scene's seed (seabed texture, noise, speckle)
    depth: float
    slope_deg: float
    slope_azimuth_deg: float
    roughness: float
    altitude: float
    tilt_deg: float
    speed: float
    fps: float
    heading_deg: float
    current: tuple[float, float]
    line_spacing: float
    lines: int
    line_length: float
    window_start: float
    window_length: float
    swath: float  # m, at the seabed onset on a flat seabed
    objects: tuple[tuple[str, float, float, float], ...]  # class, north, east, heading_deg
    sonar: SonarModelName = "didson"  # the model flown (high-frequency mode)

    def factors(self) -> dict[str, float]:
        """The factors the results are binned by."""
        return {"roughness": self.roughness, "slope_deg": self.slope_deg, "tilt_deg": self.tilt_deg,
                "altitude": self.altitude, "speed": self.speed, "fps": self.fps}

    def to_dict(self) -> dict[str, object]:
        return asdict(self)

    def scene_toml(self) -> str:
        """The scene file of this survey (loadable by ``auvlink sim --scene``)."""
        rows = [f"# auvlink eval --surveys: survey {self.index} of a random draw (auvlink.evaluation.draw)",
                f"seed = {self.seed}", "", "[seabed]", f"depth = {self.depth!r}",
                f"slope_deg = {self.slope_deg!r}", f"slope_azimuth_deg = {self.slope_azimuth_deg!r}",
                f"roughness = {self.roughness!r}", ""]
        for cls, n, e, h in self.objects:
            rows += ["[[objects]]", f'class = "{cls}"', f"position = [{n!r}, {e!r}]", f"heading_deg = {h!r}", ""]
        rows += ["[survey]", 'pattern = "lawnmower"', "origin = [0.0, 0.0]", f"heading_deg = {self.heading_deg!r}",
                 f"line_length = {self.line_length!r}", f"line_spacing = {self.line_spacing!r}",
                 f"lines = {self.lines}", f"altitude = {self.altitude!r}", f"speed = {self.speed!r}", "",
                 "[sonar]", *([f'model = "{self.sonar}"'] if self.sonar != "didson" else []),
                 f"tilt_deg = {self.tilt_deg!r}", f"spread_deg = {describe(self.sonar).vertical_aperture_deg!r}",
                 f"window_start = {self.window_start!r}", f"window_length = {self.window_length!r}",
                 f"fps = {self.fps!r}", f"lever_arm = [{LEVER_ARM[0]!r}, {LEVER_ARM[1]!r}, {LEVER_ARM[2]!r}]", "",
                 "[vehicle]", f"current = [{self.current[0]!r}, {self.current[1]!r}]", ""]
        return "\n".join(rows)


def onset_range(height: float, depression_deg: float, rise_deg: float = 0.0) -> float:
    """Slant range (m) of the steepest ray's seabed hit from ``height`` m above the seabed under the
    sonar, the ray ``depression_deg`` below horizontal, the seabed rising ahead by ``rise_deg``."""
    d, a = math.radians(depression_deg), math.radians(rise_deg)
    return height * math.cos(a) / math.sin(d + a)


def _u(rng: np.random.Generator, name: str) -> float:
    lo, hi = SPACE[name]
    return float(rng.uniform(lo, hi))


def _place(rng: np.random.Generator, n: int, across: tuple[float, float], along: tuple[float, float]
           ) -> list[tuple[float, float]] | None:
    """``n`` points (along, across) uniform in the box, at least :data:`MIN_SEPARATION` apart."""
    pts: list[tuple[float, float]] = []
    for _ in range(400 * n):
        p = (float(rng.uniform(*along)), float(rng.uniform(*across)))
        if all(math.hypot(p[0] - q[0], p[1] - q[1]) >= MIN_SEPARATION for q in pts):
            pts.append(p)
            if len(pts) == n:
                return pts
    return None


def survey_sonar(seed: int, index: int, sonar: str = "didson") -> SonarModelName:
    """The sonar model of survey ``index``: ``sonar`` itself (one of the simulated models), or for ``random`` one of
    them drawn from the survey's own stream (the other factors of the survey do not move with it)."""
    if sonar != "random":
        if sonar not in SIMULATED_MODELS:
            raise ValueError(f"sonar {sonar!r}: use random or one of {', '.join(SIMULATED_MODELS)}")
        return SIMULATED_MODELS[SIMULATED_MODELS.index(sonar)]
    rng = np.random.default_rng(np.random.SeedSequence([seed, index, 0x50AA]))
    return SIMULATED_MODELS[int(rng.integers(len(SIMULATED_MODELS)))]


def draw_survey(seed: int, index: int, small: bool = False, sonar: str = "didson") -> SurveyDraw:
    """Survey ``index`` of the draw seeded ``seed`` (see the module docstring). ``small``: 2 lines and
    2 objects, the same conditions otherwise (the CI smoke test; not part of the contract). ``sonar``: the
    model flown (:func:`survey_sonar`)."""
    model = survey_sonar(seed, index, sonar)
    fan = describe(model)
    rng = np.random.default_rng(np.random.SeedSequence([seed, index, 0x5A17E7]))
    depth, slope, rough = _u(rng, "depth"), _u(rng, "slope_deg"), _u(rng, "roughness")
    slope_az = float(rng.uniform(0.0, 360.0))
    alt, tilt = _u(rng, "altitude"), _u(rng, "tilt_deg")
    speed, fps = _u(rng, "speed"), _u(rng, "fps")
    heading = float(rng.uniform(0.0, 360.0))
    cur, cur_dir = _u(rng, "current"), float(rng.uniform(0.0, 2.0 * math.pi))
    current = (round(cur * math.cos(cur_dir), 4), round(cur * math.sin(cur_dir), 4))
    h = alt - LEVER_ARM[2]  # sonar head above the seabed
    dep = tilt + fan.vertical_aperture_deg / 2.0
    r_flat = onset_range(h, dep)
    swath = 2.0 * r_flat * math.sin(math.radians(fan.half_fov_deg))
    spacing = _u(rng, "spacing_fraction") * swath
    # the seabed's rise along the line (either direction) and across it (beams at +-the half field)
    rise = math.degrees(math.atan(math.tan(math.radians(slope)) * 1.0))
    r_near, r_far = onset_range(h, dep, rise), onset_range(h, dep, -rise)
    margin_before = MAX_OBJECT_HEIGHT / math.sin(math.radians(dep)) + float(rng.uniform(1.0, 3.0))
    w_start = round(max(0.5, r_near - margin_before), 2)
    w_len = round(r_far / math.cos(math.radians(fan.half_fov_deg)) - w_start + float(rng.uniform(1.5, 4.0)), 2)
    reach = r_far * math.cos(math.radians(dep))  # horizontal distance of the onset ahead of the sonar
    n_obj = int(rng.integers(5, 9))
    lines = int(rng.integers(3, 6))
    if small:
        n_obj, lines = 2, 2
    across = (-0.25 * swath, (lines - 1) * spacing + 0.25 * swath)
    width = across[1] - across[0]
    # long enough for the objects at the minimum separation, with room for the placement to be random
    per_row = max(1, int(width // MIN_SEPARATION) + 1)
    inner = MIN_SEPARATION * (math.ceil(n_obj / per_row) + 1.5)
    length = round(inner + 2.0 * (reach + LEVER_ARM[0] + 3.0), 1)
    along = (reach + LEVER_ARM[0] + 3.0, length - reach - LEVER_ARM[0] - 3.0)
    spots = None
    while spots is None:
        spots = _place(rng, n_obj, across, along)
        if spots is None:  # too tight for this many: lengthen the lines
            length += MIN_SEPARATION
            along = (along[0], along[1] + MIN_SEPARATION)
    psi = math.radians(heading)
    fwd, stb = np.array([math.cos(psi), math.sin(psi)]), np.array([-math.sin(psi), math.cos(psi)])
    objects = []
    for a, c in spots:
        ne = a * fwd + c * stb
        cls = CLASSES[int(rng.integers(len(CLASSES)))]
        objects.append((cls, round(float(ne[0]), 3), round(float(ne[1]), 3), round(float(rng.uniform(0, 360)), 1)))
    scene_seed = int(rng.integers(0, 2**31 - 1))
    return SurveyDraw(index=index, seed=scene_seed, depth=round(depth, 2), slope_deg=round(slope, 2),
                      slope_azimuth_deg=round(slope_az, 1), roughness=round(rough, 4), altitude=round(alt, 2),
                      tilt_deg=round(tilt, 2), speed=round(speed, 3), fps=round(fps, 2),
                      heading_deg=round(heading, 1), current=current, line_spacing=round(spacing, 3),
                      lines=lines, line_length=length, window_start=w_start, window_length=w_len,
                      swath=round(swath, 3), objects=tuple(objects), sonar=model)


def draw_surveys(n: int, seed: int, small: bool = False, sonar: str = "didson") -> list[SurveyDraw]:
    """``n`` surveys of the draw seeded ``seed``, flown with ``sonar`` (:func:`survey_sonar`)."""
    return [draw_survey(seed, i, small, sonar) for i in range(n)]
