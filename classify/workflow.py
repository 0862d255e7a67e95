"""The whole job behind ``auvlink train`` and ``auvlink eval``: synthesize from the object catalog,
train, evaluate on held-out synthesized clouds (other seed, headings, tilts and altitudes), save.
``extra_evals`` adds checks the caller owns, each stored in the metrics under its name (``auvlink train
--recon-eval``: clouds that recon reconstructs from simulated passes,
:func:`auvlink.evaluation.recon_eval.recon_metrics`; evaluation only, never training data). With clutter in the
synthesis (``clutter_clouds > 0``) the model gets a 9th output, ``clutter``, and its threshold is calibrated on the
validation split (:func:`calibrate_clutter`) and stored in the checkpoint.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from classify.checkpoint import save_checkpoint
from classify.config import TrainSettings
from classify.dataset import CloudSet, MeshSource, catalog_meshes, heldout_settings, synthesize_set
from classify.evaluate import EvalReport
from classify.infer import Classifier
from classify.labels import CLUTTER, with_clutter
from classify.synthesis import SynthesisSettings
from classify.train import TrainResult, train

#: at most this fraction of the validation split's object clouds may be called clutter (the threshold's choice)
MAX_FALSE_CLUTTER = 0.01


@dataclass
class TrainOutcome:
    path: Path
    result: TrainResult
    heldout: EvalReport
    metrics: dict[str, Any]


def set_probabilities(clf: Classifier, data: CloudSet) -> npt.NDArray[np.float32]:
    """Probabilities ``(len(data), k)`` of every cloud of ``data`` through the inference path."""
    pts = data.points * data.scale_m if data.scale_m > 0 else data.points  # back to metres
    return clf.probabilities(list(pts), batch_size=16, seabed_depths=[0.0] * len(pts))  # seabed at z = 0


def evaluate_classifier(clf: Classifier, data: CloudSet) -> EvalReport:
    """Classify every cloud of ``data`` through the inference path, with its decision rule (``clutter`` from
    the calibrated threshold); labels mapped by class name."""
    names = list(clf.class_names)
    true = np.array([names.index(data.class_names[k]) for k in data.labels])
    pred = [names.index(c) for c, _ in clf.decide(set_probabilities(clf, data))]
    return EvalReport.from_predictions(clf.class_names, true, pred)


def calibrate_clutter(clf: Classifier, data: CloudSet, max_false: float = MAX_FALSE_CLUTTER) -> dict[str, Any]:
    """The ``clutter`` threshold: the smallest probability of clutter, not below 0.5, that at most ``max_false``
    of the object clouds of ``data`` (the validation split) reach; and what it gives on ``data``."""
    if clf.clutter_index is None:
        return {}
    prob = set_probabilities(clf, data)[:, clf.clutter_index].astype(np.float64)
    is_clutter = np.array([data.class_names[k] == CLUTTER for k in data.labels])
    objects, clutter = prob[~is_clutter], prob[is_clutter]
    thr = 0.5 if objects.size == 0 else float(np.clip(np.quantile(objects, 1.0 - max_false), 0.5, 0.99))
    thr = float(np.nextafter(thr, 1.0)) if objects.size and np.mean(objects >= thr) > max_false else thr
    return {"clutter_threshold": thr, "max_false": max_false, "n_objects": int(objects.size),
            "n_clutter": int(clutter.size), "objects_called_clutter": float(np.mean(objects >= thr)) if objects.size
            else 0.0, "clutter_recall": float(np.mean(clutter >= thr)) if clutter.size else float("nan")}


def train_and_save(settings: TrainSettings, out: Path, cache_dir: Path | None = None, progress: bool = True,
                   meshes: tuple[tuple[str, ...], MeshSource] | None = None,
                   extra_evals: Mapping[str, Callable[[Classifier], dict[str, Any]]] | None = None) -> TrainOutcome:
    names, mesh_for = meshes if meshes is not None else catalog_meshes()
    names = with_clutter(names, settings.synthesis.clutter_clouds > 0)
    t0 = time.perf_counter()
    data = synthesize_set(names, mesh_for, settings.synthesis, cache_dir, progress)
    t_syn = time.perf_counter() - t0
    result = train(data, settings.train, progress=progress)
    held_settings = heldout_settings(settings.synthesis)
    held = synthesize_set(names, mesh_for, held_settings, cache_dir, progress)
    metrics: dict[str, Any] = {
        "synthesis_seconds": t_syn, "train_seconds": result.seconds, "best_epoch": result.best_epoch,
        "epochs_run": len(result.history), "val_accuracy": result.val_accuracy, "n_train_clouds": len(data),
        "history": result.history, "config_source": settings.source,
    }
    path = save_checkpoint(out, result.model, names, settings.train.n_points, settings.synthesis.to_dict(),
                           settings.train.to_dict(), metrics)
    calibration = calibrate_clutter(Classifier.load(path), data.subset(result.val_idx))
    metrics["calibration"] = calibration
    path = save_checkpoint(out, result.model, names, settings.train.n_points, settings.synthesis.to_dict(),
                           settings.train.to_dict(), metrics, calibration)
    report = evaluate_classifier(Classifier.load(path), held)
    metrics["heldout"] = {"settings": held_settings.to_dict(), **report.to_dict()}
    for key, check in (extra_evals or {}).items():
        metrics[key] = check(Classifier.load(path))
    save_checkpoint(out, result.model, names, settings.train.n_points, settings.synthesis.to_dict(),
                    settings.train.to_dict(), metrics, calibration)
    return TrainOutcome(path, result, report, metrics)


def heldout_set(synthesis: dict[str, Any] | SynthesisSettings, class_names: tuple[str, ...],
                cache_dir: Path | None, seed: int | None = None, progress: bool = False,
                mesh_for: MeshSource | None = None, thin: bool = False) -> CloudSet:
    """Held-out clouds for a checkpoint's synthesis settings (``thin``: every 3rd heading, 2 tilts, 1 draw)."""
    syn = synthesis if isinstance(synthesis, SynthesisSettings) else SynthesisSettings.from_dict(synthesis)
    if mesh_for is None:
        _, mesh_for = catalog_meshes()
    held = heldout_settings(syn, seed)
    if thin:
        views = len(held.directions) * held.copies
        held = replace(held, headings_deg=held.headings_deg[::3], tilts_deg=held.tilts_deg[1::2], copies=1)
        held = replace(held, clutter_clouds=max(8, round(held.clutter_clouds * len(held.directions) / views)))
    return synthesize_set(class_names, mesh_for, held, cache_dir, progress)
