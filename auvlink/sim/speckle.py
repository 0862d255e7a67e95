"""Return strength, speckle and 8-bit quantization of the simulated sonar image.

Per ray (Sung et al. 2021, section 4.1.1)::

    I = w (z - z0) / (z + z0) * I0 * cos^2(alpha) / |p|^2

``w`` a material weight, ``z`` the material's and ``z0`` the water's acoustic impedance, ``I0`` the
source level, ``alpha`` the incidence angle between the ray and the surface normal and ``|p|`` the
range. The image sums the returns of all rays of a beam that fall in the same range bin
(equation 9). Speckle (equation 10): each cell gets ``s(r, theta) ~ U[0, s_max]`` Gaussian phasors
of variance ``sigma^2`` each; their sum is one circular complex Gaussian ``n`` of variance
``s sigma^2``, and the cell's value is ``A = |I + n|``.

Quantization (fixed gain, log compression, documented for the decoder side): with
``L = 10 log10(A)`` dB, ``u8 = clip(floor((L - floor_db) * 256 / range_db), 0, 255)``; i.e. 0 below
``floor_db`` and 255 at or above ``floor_db + range_db * 255 / 256``. A cell with no return and no
speckle is 0.

Speed: most cells hold no return; their value depends only on ``|n|``, so they are drawn from the
exact distribution of the quantized ``|n|`` by inverse-CDF lookup of one uniform 16-bit integer per
cell (table of 65536 entries built once by numerical integration; exact to 2^-16 in probability).
Cells with a return draw ``s``, ``|n|^2 = s sigma^2 E`` (``E ~ Exp(1)``) and the phase explicitly, in
float32 (ample for an 8-bit output). ``exact=True`` draws explicitly everywhere (slower; used to
check the table).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from auvlink.sim.object_meshes import MATERIALS, Material

F64 = NDArray[np.float64]
U8 = NDArray[np.uint8]


@dataclass(frozen=True)
class AcousticModel:
    """Constants of the return, speckle and quantization model (see the module docstring)."""

    source_level: float = 1000.0  # I0 (arbitrary units; a steel face at 8 m returns ~12)
    seabed_material: Material = MATERIALS["sand"]
    noise_sigma: float = 0.02  # rms amplitude of one speckle phasor
    speckle_max: float = 10.0  # s(r, theta) ~ U[0, speckle_max]
    floor_db: float = -25.0  # 10 log10(A) that maps to 0
    range_db: float = 50.0  # dB spanned by 0..256

    @cached_property
    def thresholds(self) -> F64:
        """Amplitudes ``a_k`` (k = 1..255) where the quantized value steps from ``k - 1`` to ``k``."""
        k = np.arange(1, 256)
        return np.asarray(10.0 ** ((self.floor_db + k * self.range_db / 256.0) / 10.0))

    def quantize(self, amplitude: F64) -> U8:
        """Log-compress amplitudes into uint8 (0 for an amplitude of 0)."""
        return self._quantize_power(np.square(np.asarray(amplitude, np.float32)))

    def _quantize_power(self, power: NDArray[np.float32]) -> U8:
        """``q`` from ``A^2``: ``floor((5 log10(A^2) - floor_db) * 256 / range_db)`` clipped to 0..255."""
        with np.errstate(divide="ignore"):
            level = np.log10(power) * np.float32(5.0 * 256.0 / self.range_db)
        level -= np.float32(self.floor_db * 256.0 / self.range_db)
        return np.clip(np.floor(level), 0.0, 255.0).astype(np.uint8)

    @cached_property
    def noise_table(self) -> U8:
        """65536-entry inverse CDF of the quantized pure-speckle value ``q(|n|)``."""
        # P(|n| < a) = mean over s of (1 - exp(-a^2 / (s sigma^2))), s ~ U[0, s_max] (midpoint rule)
        s = (np.arange(4096) + 0.5) / 4096 * self.speckle_max
        a2 = self.thresholds[:, None] ** 2
        cdf = 1.0 - np.exp(-a2 / (s[None, :] * self.noise_sigma**2)).mean(axis=1)  # P(u8 < k+1)
        q = (np.arange(65536) + 0.5) / 65536.0
        return np.searchsorted(cdf, q, side="right").astype(np.uint8)

    def speckle(self, image: F64, rng: np.random.Generator, exact: bool = False) -> U8:
        """Quantized speckled image ``q(|I + n|)``, same shape as ``image``."""
        flat = image.reshape(-1)
        if exact:
            return self._explicit(flat, rng).reshape(image.shape)
        cells = np.flatnonzero(flat != 0.0)
        return self.speckle_cells(flat.size, cells, flat[cells], rng).reshape(image.shape)

    def speckle_cells(self, size: int, cells: NDArray[np.int64], values: F64, rng: np.random.Generator) -> U8:
        """Flat speckled image of ``size`` cells where only ``cells`` (sorted, unique) hold returns."""
        raw = rng.bit_generator.random_raw((size + 3) // 4).astype("<u8", copy=False)
        out = np.take(self.noise_table, raw.view("<u2")[:size])
        if cells.size:
            out[cells] = self._explicit(values, rng)
        return out

    def _explicit(self, values: F64, rng: np.random.Generator) -> U8:
        """``q(|I + n|)`` with ``n = sqrt(s sigma^2 E) exp(i psi)``: ``s ~ U[0, s_max]``,
        ``E ~ Exp(1)``, ``psi ~ U[0, 2 pi)``, i.e. a circular complex Gaussian of variance
        ``s sigma^2`` (the sum of ``s`` phasors of variance ``sigma^2``)."""
        u = rng.random((3, values.size), dtype=np.float32)
        var = u[0] * np.float32(self.speckle_max * self.noise_sigma**2)  # s sigma^2
        mag2 = var * -np.log1p(-u[1])  # |n|^2 = s sigma^2 E
        i = values.astype(np.float32)
        power = i * i + mag2 + 2.0 * i * np.sqrt(mag2) * np.cos(u[2] * np.float32(2.0 * np.pi))
        return self._quantize_power(power)
