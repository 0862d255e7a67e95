"""Classes for the objects the engine finalizes, and its clutter rule.

:class:`ObjectLabeller` classifies the objects of one emission (one clustering poll) with the classifier, loaded
on first use (the checkpoint's inference export, run with NumPy, when it matches the checkpoint: PyTorch is then
never imported; else the checkpoint with PyTorch, :func:`classify.numpy_infer.load_classifier`), and records every
classification's probability of ``clutter`` (:attr:`ObjectLabeller.scores`, what ``auvlink eval --clutter-sweep``
replays the rule on). The rule: an object the classifier calls clutter is not reported (its id is counted in
:attr:`ObjectLabeller.clutter`); a later pass fused into it (same id) is classified afresh, and an id once reported
is never made clutter.

When an object is classified: the engine hands over an object only when recon finalizes it (the vehicle is past
it) or when a later pass fused into it changes its points. A reported object's later pass is classified at once only
when its evidence changed enough to matter since its last classification: its points grew by
:data:`RECLASSIFY_GROWTH` or more, or one axis of its extent changed by more than :data:`RECLASSIFY_EXTENT` of
itself; otherwise it keeps its class for now and is classified on its final cloud at the end of the mission
(:meth:`ObjectLabeller.take_deferred`, :meth:`auvlink.pipeline.engine.Engine.finish`), so the final classes are
those of every object's final cloud. Nothing is classified twice for the same points: the class probabilities are
cached by the cloud's content (a BLAKE2 digest of its float64 points and its seabed depth, :func:`cloud_key`), so an
emission whose cloud did not change reuses them (:attr:`ObjectLabeller.forward_clouds` counts the clouds run through
the network, :attr:`ObjectLabeller.cache_hits` the reused ones).
The classifier's threads are set for the process's role when it loads (:data:`TORCH_THREADS`, passed by whoever knows
the role: replay, live, a batch or evaluation worker): NumPy's BLAS threads during each forward pass, or PyTorch's
intra-op threads.
:func:`make_detection` turns a finalized object and its class into the :class:`Detection` handed on.
"""

from __future__ import annotations

import hashlib
from collections.abc import Container, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from auvlink.pipeline.results import Detection
from classify.decision import EVIDENCE
from classify.labels import CLUTTER
from recon.cluster import DetectedObject

if TYPE_CHECKING:
    from classify.cloud_classifier import CloudClassifier

#: the classifier's threads per process role (NumPy's BLAS threads during a forward pass, or PyTorch's intra-op
#: threads on the PyTorch path). One everywhere: a poll's forward pass is small (<= 16 clouds x 4 views
#: x 256 points), so a second thread mostly waits, and it competes with the rest of the process and, in a batch or
#: evaluation, with the other workers (demo clouds, this 2-core machine under load 3.5: 8 clouds in 0.21 s on one
#: thread, 0.63-2.0 s on two, PyTorch; notes/replay_speed). Live: the frame path must not wait for a classification.
TORCH_THREADS = {"replay": 1, "live": 1, "batch": 1}
#: a reported object's later pass is classified at once when its points grew by this factor since its last
#: classification (a pass that adds a quarter more points can show a side not seen before)
RECLASSIFY_GROWTH = 1.25
#: ... or when one axis of its extent changed by more than this fraction of itself (a new side or height seen)
RECLASSIFY_EXTENT = 0.2


def cloud_key(points: npt.ArrayLike, seabed_depth: float) -> bytes:
    """A digest of a cloud's points (float64, C order, with its shape) and its seabed depth (m): equal keys, equal
    classifier inputs."""
    p = np.ascontiguousarray(points, dtype=np.float64)
    h = hashlib.blake2b(digest_size=16)
    h.update(np.asarray(p.shape, dtype=np.int64).tobytes())
    h.update(p.tobytes())
    h.update(np.float64(seabed_depth).tobytes())
    return h.digest()


class ObjectLabeller:
    """``enabled`` False: every object is ``unknown`` (no classifier). ``clutter_threshold`` replaces the
    checkpoint's (None: the checkpoint's; ``math.inf``: nothing is called clutter). ``torch_threads``: the
    classifier's threads (BLAS threads of its NumPy forward pass, or PyTorch's intra-op threads), set when it loads
    (the process's role, :data:`TORCH_THREADS`; None: left as they are)."""

    def __init__(self, enabled: bool, model: Path | None, clutter_threshold: float | None = None,
                 torch_threads: int | None = None) -> None:
        self.enabled, self.model, self.clutter_threshold = enabled, model, clutter_threshold
        self.torch_threads = torch_threads
        self.classifier: CloudClassifier | None = None
        self.clutter: set[int] = set()  # ids of the clusters called clutter (not reported)
        #: (object id, probability of clutter) of every classification, in order: an id appears once per emission
        self.scores: list[tuple[int, float]] = []
        self._cache: dict[bytes, npt.NDArray[np.float32]] = {}  # cloud_key -> class probabilities
        self.forward_clouds = 0  # clouds run through the network
        self.cache_hits = 0  # clouds whose probabilities came from the cache
        #: id -> (points, extent m, (class, score)) at its last classification
        self._evidence: dict[int, tuple[int, npt.NDArray[np.float64], tuple[str, float]]] = {}
        self._deferred: dict[int, DetectedObject] = {}  # id -> its latest object, classified at the end

    def load(self) -> None:
        """Load the classifier now (live does it before opening the ports): the checkpoint's inference export
        (NumPy) when it matches the checkpoint, else the checkpoint with PyTorch
        (:func:`classify.numpy_infer.load_classifier`)."""
        if self.enabled and self.classifier is None:
            from classify.numpy_infer import load_classifier  # lazy: a run that does not classify loads no model

            self.classifier = load_classifier(self.model, threads=self.torch_threads)
            if self.clutter_threshold is not None:
                self.classifier.set_clutter_threshold(float(self.clutter_threshold))

    def label(self, objects: Sequence[DetectedObject], reported: Container[int], final: bool = False
              ) -> list[tuple[str, float]]:
        """(class, score) per object; :data:`classify.labels.CLUTTER` for those not to report (never an id in
        ``reported``). The clutter set follows: an id called clutter joins it, one reported leaves it. A reported
        object whose evidence barely changed keeps its last class (see the module doc) unless ``final``."""
        labels: list[tuple[str, float]] = [("unknown", 0.0)] * len(objects)
        if self.enabled and objects:
            keep = [not final and int(o.id) in reported and self._small_change(o) for o in objects]
            fresh = [o for o, k in zip(objects, keep, strict=True) if not k]
            new = iter(self._classify(fresh, reported) if fresh else [])
            labels = [self._evidence[int(o.id)][2] if k else next(new) for o, k in zip(objects, keep, strict=True)]
            for o, k in zip(objects, keep, strict=True):
                if k:
                    self._deferred[int(o.id)] = o
                else:
                    self._deferred.pop(int(o.id), None)
        for o, (c, _) in zip(objects, labels, strict=True):
            if c == CLUTTER:
                self.clutter.add(int(o.id))
            else:
                self.clutter.discard(int(o.id))
        return labels

    def _small_change(self, o: DetectedObject) -> bool:
        """True when ``o`` was classified before and has not changed enough since (the module doc's rule)."""
        seen = self._evidence.get(int(o.id))
        if seen is None:
            return False
        n, extent, _ = seen
        grown = int(o.n_points) >= RECLASSIFY_GROWTH * n
        moved = np.any(np.abs(np.asarray(o.extent, dtype=np.float64) - extent) > RECLASSIFY_EXTENT * extent)
        return not (grown or bool(moved))

    def _classify(self, objects: Sequence[DetectedObject], reported: Container[int]) -> list[tuple[str, float]]:
        """Run the classifier on ``objects`` (one batch) and remember each one's evidence."""
        self.load()
        clf = self.classifier
        assert clf is not None
        prob = self.probabilities(clf, objects)
        evidence = np.stack([object_evidence(o) for o in objects])
        labels, decided = clf.decide_with_probabilities(
            prob, allow_clutter=[int(o.id) not in reported for o in objects],
            shadow_heights=[float(o.shadow_height) for o in objects], evidence=evidence)
        if clf.clutter_index is not None:  # the probability of clutter the rule saw
            self.scores += [(int(o.id), float(q)) for o, q in zip(objects, decided[:, clf.clutter_index],
                                                                  strict=True)]
        for o, lab in zip(objects, labels, strict=True):
            self._evidence[int(o.id)] = (int(o.n_points), np.asarray(o.extent, dtype=np.float64).copy(), lab)
        return labels

    def take_deferred(self) -> list[DetectedObject]:
        """The objects whose latest pass kept an earlier class (to classify on their final cloud), forgotten here."""
        out, self._deferred = list(self._deferred.values()), {}
        return out

    def probabilities(self, clf: CloudClassifier, objects: Sequence[DetectedObject]) -> npt.NDArray[np.float32]:
        """Class probabilities ``(len(objects), k)``: from the cache for a cloud classified before, the others in
        one :meth:`~classify.cloud_classifier.CloudClassifier.probabilities`
        call (recon fitted the seabed for the poll; each object carries it)."""
        keys = [cloud_key(o.points, float(o.seabed_depth)) for o in objects]
        todo = sorted({k: i for i, k in enumerate(keys) if k not in self._cache}.values())
        if todo:
            fresh = clf.probabilities([objects[i].points for i in todo],
                                      seabed_depths=[float(objects[i].seabed_depth) for i in todo])
            self._cache.update({keys[i]: row for i, row in zip(todo, fresh, strict=True)})
            self.forward_clouds += len(todo)
        self.cache_hits += len(objects) - len(todo)
        return np.stack([self._cache[k] for k in keys])


#: of the depths of an object's points: its top (a quantile, not the shallowest point: one stray point is no top)
TOP_QUANTILE = 0.05


def object_evidence(o: DetectedObject) -> npt.NDArray[np.float64]:
    """What recon measured of a finalized object besides its cloud, as :data:`classify.decision.EVIDENCE` orders it
    (NaN where unknown): its shadow height and readings (:class:`recon.shadow.ShadowReading`), extent, top over the
    seabed (the :data:`TOP_QUANTILE` of its points' depths), points and time span."""
    pts = np.asarray(o.points, dtype=np.float64).reshape(-1, 3)
    sd = float(o.seabed_depth)
    top = sd - float(np.quantile(pts[:, 2], TOP_QUANTILE)) if len(pts) and np.isfinite(sd) else np.nan
    r = o.shadow
    ev = np.array([o.shadow_height, *np.asarray(o.extent, dtype=np.float64)[:3], top, o.n_points,
                   o.t_last - o.t_first, *r.footprint_quantiles_m, *r.ring_quantiles_m, r.footprint_tops,
                   r.ring_tops], dtype=np.float64)
    assert ev.shape == (len(EVIDENCE),)
    return ev


def make_detection(o: DetectedObject, class_name: str, score: float, shift: npt.NDArray[np.float64],
                   epoch: float) -> Detection:
    """The detection of the finalized object ``o``: its points and centre moved by ``shift`` (m, the frame D ->
    W shift), its times made absolute (``epoch``: the mission's start, s since 1970)."""
    centre = np.asarray(o.centroid, dtype=np.float64) + shift
    return Detection(id=int(o.id), class_name=class_name, score=float(score),
                     position_ned=(float(centre[0]), float(centre[1]), float(centre[2])),
                     size=(float(o.extent[0]), float(o.extent[1]), float(o.extent[2])),
                     n_points=int(o.n_points), t_first=epoch + float(o.t_first),
                     t_last=epoch + float(o.t_last), points=o.points + shift if np.any(shift) else o.points,
                     times=epoch + np.asarray(o.times, dtype=np.float64),
                     passes=tuple((epoch + a, epoch + b) for a, b in getattr(o, "passes", ())),
                     seabed_depth=float(o.seabed_depth) if np.isfinite(o.seabed_depth) else None,
                     shadow_height=float(o.shadow_height) if np.isfinite(o.shadow_height) else None,
                     evidence=tuple(float(v) for v in object_evidence(o)))
