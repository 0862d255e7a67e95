"""Noise of the simulated sensors: the optional ``[noise]`` table of a scene file, and seeded streams.

Every key has a default (the table itself is optional; :mod:`auvlink.sim.settings` parses it).
``noise = false`` at the top level (or ``[noise] enabled = false``) gives the noise-free mode: every
sensor reports the truth, changed only by its wire quantization, and the DVL never drops out.

.. code-block:: toml

    [noise.dvl]                  # white unless said otherwise; sigmas are 1-sigma
    velocity_sigma = 0.003       # m/s per ship axis (and the error velocity)
    scale_error = 0.001          # reported velocity = (1 + scale_error) x true
    range_sigma = 0.01           # m per beam (vertical range)
    dropout_probability = 0.01   # per ping: all four beams bad (-32768 velocity, 0 range)
    heading_sigma_deg = 0.5      # its own compass
    attitude_sigma_deg = 0.1     # its own pitch and roll
    temperature_sigma_c = 0.02
    [noise.gyro]                 # KVH DSP-1760 datasheet figures
    arw_deg_per_sqrt_h = 0.012   # angle random walk (white rate noise)
    bias_instability_deg_per_h = 0.05   # first-order Gauss-Markov bias, this steady-state sigma
    bias_correlation_s = 300.0
    accel_noise_density = 0.001  # m/s^2/sqrt(Hz), white
    [noise.pressure]             # sigma = 0.01 % of a 20 bar (about 290 psia) full scale
    sigma_fs = 1.0e-4
    full_scale_pa = 2.0e6
    [noise.ahrs]                 # the attitude on the CAN bus
    heading_sigma_deg = 0.1
    attitude_sigma_deg = 0.05

Randomness: :func:`stream_rng` gives each (sensor, quantity) its own ``numpy.random.Generator``
seeded from the run's seed, so adding a sensor or a quantity never changes another's bytes, and
the draws of a longer run begin with those of a shorter one.
"""


from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, field, fields, replace
from typing import Annotated, Any

import numpy as np
from pydantic import Field
from pydantic.dataclasses import dataclass as model

from auvlink.errors import AuvlinkError
from auvlink.validation import CONFIG, Number


class SimError(AuvlinkError):
    """The simulator cannot run as asked (a device it cannot emit, a port it cannot serve)."""


#: a noise magnitude (>= 0; finite)
Sigma = Annotated[Number, Field(ge=0.0, le=1.0e6)]
Fraction = Annotated[Number, Field(ge=0.0, le=1.0)]


@model(frozen=True, config=CONFIG)
class DvlNoise:
    velocity_sigma: Sigma = 0.003
    scale_error: Annotated[Number, Field(ge=-0.1, le=1.0)] = 0.001
    range_sigma: Sigma = 0.01
    dropout_probability: Fraction = 0.01
    heading_sigma_deg: Sigma = 0.5
    attitude_sigma_deg: Sigma = 0.1
    temperature_sigma_c: Sigma = 0.02


@model(frozen=True, config=CONFIG)
class GyroNoise:
    arw_deg_per_sqrt_h: Sigma = 0.012
    bias_instability_deg_per_h: Sigma = 0.05
    bias_correlation_s: Annotated[Number, Field(gt=0.0, le=1.0e6)] = 300.0
    accel_noise_density: Sigma = 0.001

    @property
    def arw(self) -> float:  # rad/sqrt(s)
        return math.radians(self.arw_deg_per_sqrt_h) / 60.0

    @property
    def bias_sigma(self) -> float:  # rad/s
        return math.radians(self.bias_instability_deg_per_h) / 3600.0


@model(frozen=True, config=CONFIG)
class PressureNoise:
    sigma_fs: Fraction = 1.0e-4
    full_scale_pa: Annotated[Number, Field(gt=0.0, le=1.0e9)] = 2.0e6

    @property
    def sigma_pa(self) -> float:  # Pa
        return self.sigma_fs * self.full_scale_pa


@model(frozen=True, config=CONFIG)
class AhrsNoise:
    heading_sigma_deg: Sigma = 0.1
    attitude_sigma_deg: Sigma = 0.05


#: fields that keep their value in the noise-free mode (they shape noise, they are not noise)
SHAPE_FIELDS = {"bias_correlation_s", "full_scale_pa"}


def _quiet(obj: Any) -> Any:
    return replace(obj, **{f.name: 0.0 for f in fields(obj) if f.name not in SHAPE_FIELDS})


@dataclass(frozen=True)
class NoiseConfig:
    enabled: bool = True
    dvl: DvlNoise = field(default_factory=DvlNoise)
    gyro: GyroNoise = field(default_factory=GyroNoise)
    pressure: PressureNoise = field(default_factory=PressureNoise)
    ahrs: AhrsNoise = field(default_factory=AhrsNoise)

    @classmethod
    def off(cls) -> NoiseConfig:
        """The noise-free mode: every magnitude zero, no dropouts."""
        return cls(False, _quiet(DvlNoise()), _quiet(GyroNoise()), _quiet(PressureNoise()), _quiet(AhrsNoise()))


# --- random streams --------------------------------------------------------------------------
def stream_rng(seed: int, sensor: str, quantity: str) -> np.random.Generator:
    """The generator of one noise quantity of one sensor (independent of every other stream)."""
    tags = [zlib.crc32(sensor.encode()), zlib.crc32(quantity.encode())]
    return np.random.default_rng(np.random.SeedSequence([seed, 0x5E45, *tags]))
