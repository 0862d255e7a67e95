"""The azimuth beam pattern of the realistic image model (:mod:`auvlink.sim.acoustic_image`, step 3).

Each beam receives the returns on every beam's axis through its two-way response: a gaussian main lobe,
-3 dB at ``width_beams / 2`` beam spacings, and sidelobes from two beams off at ``sidelobe_db`` falling as
``(2 / k)^2`` with the offset ``k`` in beams (the ``1/x^2`` envelope of a uniformly weighted aperture's
sinc^2), whichever is higher, across the whole fan. The response depends on the offset alone (a Toeplitz
matrix), so mixing the beams of every range line is a linear convolution along the beams:
:class:`AzimuthMixer` does it by real FFTs of ``next_fast_len(2 n - 1)`` points (no wrap-around: the kernel
spans offsets ``-(n - 1)..n - 1``), ``O(n log n)`` per range line instead of the matrix product's ``O(n^2)``
(:func:`spread_across_beams`, kept as the reference the tests compare with).

Layout: energies are range-major, ``(range lines, beams)`` float32, as the image ``[range bin, beam]``.
"""

from __future__ import annotations

import math
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray
from scipy import fft

F64 = NDArray[np.float64]
F32 = NDArray[np.float32]


def azimuth_kernel(offset: F64, width_beams: float, sidelobe_db: float) -> F64:
    """Two-way response at ``offset`` beams (any sign) off a beam's axis (module docstring)."""
    k = np.abs(np.asarray(offset, float))
    main = np.exp(-4.0 * math.log(2.0) * (k / width_beams) ** 2)
    side = 10.0 ** (sidelobe_db / 10.0) * (2.0 / np.maximum(k, 2.0)) ** 2
    return np.where(k >= 2.0, np.maximum(main, side), main)


def beam_mixing(n_beams: int, width_beams: float, sidelobe_db: float) -> F64:
    """(n_beams, n_beams) response matrix: row ``i`` = how beam ``i`` receives a return on each beam's axis."""
    offset = np.arange(n_beams)[:, None] - np.arange(n_beams)[None, :]
    return azimuth_kernel(offset.astype(float), width_beams, sidelobe_db)


FArray = TypeVar("FArray", NDArray[np.float32], NDArray[np.float64])


def spread_across_beams(energy: FArray, mixing: FArray) -> FArray:
    """Reference: range-major energies ``(lines, beams)`` through the response matrix ``mixing`` (one GEMM)."""
    out: FArray = energy @ mixing.T
    return out


class AzimuthMixer:
    """The response of :func:`beam_mixing` applied by FFT convolution; the kernel's spectrum built once per sonar."""

    def __init__(self, n_beams: int, width_beams: float, sidelobe_db: float) -> None:
        self.n_beams = n_beams
        self.size = fft.next_fast_len(2 * n_beams - 1, real=True)
        offset = np.arange(self.size, dtype=float)
        offset = np.where(offset < n_beams, offset, offset - self.size)  # circular: offsets -(n-1)..n-1 fit
        kernel = azimuth_kernel(offset, width_beams, sidelobe_db)
        kernel[np.abs(offset) >= n_beams] = 0.0
        # an even real kernel has a real spectrum: multiply by its real part (float32, ample for 8 bits)
        self.spectrum = np.asarray(fft.rfft(kernel).real, np.float32)

    def __call__(self, energy: F32) -> F32:
        """Range-major ``(lines, beams)`` float32 energies mixed across the beams of each line."""
        if energy.shape[0] == 0:
            return energy.copy()
        spec = fft.rfft(energy, n=self.size, axis=1, workers=1)
        spec *= self.spectrum
        out = fft.irfft(spec, n=self.size, axis=1, workers=1)[:, : self.n_beams]
        return np.maximum(out, np.float32(0.0), dtype=np.float32)
