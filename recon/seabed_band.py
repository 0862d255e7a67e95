"""The seabed return of each column (frame, beam), and the expected onset corrected by it.

Recon places every return on the steepest ray of its beam (elevation ``t + s/2``). That is right for a
column's *first* return: the steepest ray meets the seabed (or a crest, or an object) nearest. A later
return comes from a shallower ray, and placed on the steepest ray it lies *under* the seabed. So the seabed
sample of a column is its first return near the expected onset (:func:`seabed_returns`): the first bin above
the frame's threshold from ``lead_m`` of range before the expected onset to ``band_m`` after it. One bin is
enough (``min_run``): the steepest ray's return is one ray in one bin. Searching from before the onset keeps
a seabed fitted too deep from pushing its own samples deeper still.

The expected onset itself (:class:`OnsetTracker`): the seabed fitted so far predicts it, and the
measured returns correct it where the fit is off (ahead of a new line, over a crest field the tiles do
not follow). Per beam, the correction is tracked from frame to frame: each frame, the returns within
``gate_m`` of the previous correction (the seabed; an object's returns come earlier, the seabed in its
shadow later, and an object near the sonar can fill most of the fan) refit a line across the beams.
When the fit behind the prediction changes, the correction is carried over (:meth:`OnsetTracker.rebase`),
so it stays continuous; a frame with too few returns near it leaves it as it is.
After ``reacquire`` such frames in a row it is taken afresh: the median of the frame's returns.
It never puts the onset more than ``max_deeper_m`` beyond the fit's: a seabed searched past its true onset
turns into highlight points, while an onset put too near only shortens the highlights. While the seabed fitted
so far spans less than ``known_span_m`` (the first metres of a survey: the slope ahead is not known, and a
flat prediction on a 5-10 deg slope puts the onset 0.3-1 m of range too near, so that every object lower than
that error is taken for the seabed), the limit is ``band_m``, the end of the seabed search
(:attr:`OnsetTracker.deeper_m`). The highlight search uses the corrected onset.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from recon.highlight import onset_rows, returns_between
from recon.sonar_geometry import SonarGeometry

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]


@dataclass(frozen=True)
class BandConfig:
    """The seabed band search (:func:`seabed_returns`) and the onset tracking (:class:`OnsetTracker`)."""

    lead_m: float = 1.0  # m of range: search from this far before the expected onset (its error must be less)
    lead_flat_m: float = 3.0  # m of range: the same while the seabed fitted so far spans less than ...
    known_span_m: float = 15.0  # m (its slope is not known yet)
    band_m: float = 1.0  # m of range: ... to this far after it
    min_run: int = 1  # bins above the threshold (the steepest ray's return is one bin)
    min_beams: int = 16  # returns on the seabed needed to correct the onset
    sample_lead_m: float = 0.3  # m of range: seabed samples at most this far before the corrected onset
    # fraction of the way to each frame's fit: a fit error persists while the vehicle flies over it, a low
    # object wide across the fan (a pipe) looks like a seabed shift for only the few frames it is a highlight
    rate: float = 0.1
    gate_m: float = 0.15  # m of range: returns this near the previous correction are the seabed's
    reacquire: int = 8  # frames in a row without enough of them: the correction is the median of the returns
    # m of range: the onset is never moved farther than this beyond the fit's (a seabed searched past its true
    # onset turns into highlight points; an onset put too near only shortens the highlights)
    max_deeper_m: float = 0.1


#: the seabed band search and onset tracking recon runs with (fixed: their sources are the comments above)
SEABED_BAND = BandConfig()


def seabed_returns(geometry: SonarGeometry, images: NDArray[np.uint8], onset: F64, thr: F64, margin_m: float,
                   cfg: BandConfig, lead_m: float | None = None) -> tuple[I64, I64, I64]:
    """(frame, beam, row) of each column's first return near its expected ``onset`` (F, beams) m, searched
    from ``lead_m`` (default ``cfg.lead_m``) before it."""
    lo = onset_rows(geometry, onset, margin_m + (cfg.lead_m if lead_m is None else lead_m))
    hi = onset_rows(geometry, onset, margin_m - cfg.band_m)
    return returns_between(images, lo, hi, thr, cfg.min_run)


class OnsetTracker:
    """Per-beam correction (m of range) of the expected onset, tracked over frames; see the module docstring."""

    def __init__(self, n_beams: int, cfg: BandConfig) -> None:
        self.cfg = cfg
        self.est = np.zeros(n_beams)
        self.ready = False  # the first frame with enough returns sets the correction outright
        self._misses = 0  # frames in a row without enough returns near the correction
        self._beams = np.arange(n_beams, dtype=np.float64)
        #: m of range: how far beyond the fit's onset the correction may go (:meth:`set_known`)
        self.deeper_m = cfg.max_deeper_m

    def set_known(self, known: bool) -> None:
        """Whether the fit's slope ahead is known: ``max_deeper_m`` then, else ``band_m``."""
        self.deeper_m = self.cfg.max_deeper_m if known else max(self.cfg.max_deeper_m, self.cfg.band_m)

    def rebase(self, delta: F64) -> None:
        """The prediction moved by ``-delta`` (new fit): keep the corrected onset where it was."""
        self.est = np.clip(self.est + np.asarray(delta, np.float64), -self.cfg.lead_flat_m, self.deeper_m)

    def correct(self, geometry: SonarGeometry, onset: F64, fi: I64, bi: I64, ri: I64) -> F64:
        """Corrected onsets (F, beams) m of the frames of a batch, in time order."""
        cfg = self.cfg
        f, nb = onset.shape
        d = np.full((f, nb), np.nan)
        d[fi, bi] = geometry.ranges[ri] - onset[fi, bi]
        out = np.empty((f, nb))
        for k in range(f):
            row = d[k]
            if not self.ready and np.isfinite(row).sum() >= cfg.min_beams:
                self.est = np.full(nb, float(np.nanmedian(row)))
                self.ready = True
            inl = np.isfinite(row) & (np.abs(row - self.est) <= cfg.gate_m)
            if inl.sum() >= cfg.min_beams:
                self.est = self.est + cfg.rate * (self._line(self._beams[inl], row[inl]) - self.est)
                self._misses = 0
            else:
                # too few returns near it: an object fills the fan (for a few frames), or the fit's error changed
                # faster than the correction follows (a turn sweeps the fan over seabed the fit knows less)
                self._misses += 1
                ok = np.isfinite(row)
                if self._misses >= cfg.reacquire and ok.sum() >= cfg.min_beams:
                    self.est = np.full(nb, float(np.median(row[ok])))
                    self._misses = 0
            self.est = np.clip(self.est, -cfg.lead_flat_m, self.deeper_m)
            out[k] = onset[k] + self.est
        return out

    def _line(self, b: F64, y: F64) -> F64:
        """Least-squares line through (beam, correction), evaluated at every beam (a constant when the
        beams span less than a quarter of the fan)."""
        if b[-1] - b[0] < 0.25 * self._beams.size:  # beams ascending
            return np.full(self._beams.size, float(np.median(y)))
        bm, ym = b.mean(), y.mean()
        db = b - bm
        slope = float(db @ (y - ym)) / float(db @ db)
        return np.asarray(ym + slope * (self._beams - bm), dtype=np.float64)
