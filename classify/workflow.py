"""The whole job behind ``auvlink train`` and ``auvlink eval``: synthesize from the object catalog,
train, evaluate on held-out synthesized clouds (other seed, headings, tilts and altitudes), save.
``extra_evals`` adds checks the caller owns, each stored in the metrics under its name (``auvlink train
--recon-eval``: clouds that recon reconstructs from simulated passes,
:func:`auvlink.evaluation.recon_eval.recon_metrics`; evaluation only, never training data).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from classify.checkpoint import save_checkpoint
from classify.config import TrainSettings
from classify.dataset import CloudSet, MeshSource, catalog_meshes, heldout_settings, synthesize_set
from classify.evaluate import EvalReport
from classify.infer import Classifier
from classify.synthesis import SynthesisSettings
from classify.train import TrainResult, train


@dataclass
class TrainOutcome:
    path: Path
    result: TrainResult
    heldout: EvalReport
    metrics: dict[str, Any]


def evaluate_classifier(clf: Classifier, data: CloudSet) -> EvalReport:
    """Classify every cloud of ``data`` through the inference path (labels mapped by class name)."""
    pts = data.points * data.scale_m if data.scale_m > 0 else data.points  # back to metres
    probs = clf.probabilities(list(pts), batch_size=16, seabed_depths=[0.0] * len(pts))  # object frame: seabed z = 0
    names = list(clf.class_names)
    true = np.array([names.index(data.class_names[k]) for k in data.labels])
    return EvalReport.from_predictions(clf.class_names, true, probs.argmax(axis=1))


def train_and_save(settings: TrainSettings, out: Path, cache_dir: Path | None = None, progress: bool = True,
                   meshes: tuple[tuple[str, ...], MeshSource] | None = None,
                   extra_evals: Mapping[str, Callable[[Classifier], dict[str, Any]]] | None = None) -> TrainOutcome:
    names, mesh_for = meshes if meshes is not None else catalog_meshes()
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
    report = evaluate_classifier(Classifier.load(path), held)
    metrics["heldout"] = {"settings": held_settings.to_dict(), **report.to_dict()}
    for key, check in (extra_evals or {}).items():
        metrics[key] = check(Classifier.load(path))
    save_checkpoint(out, result.model, names, settings.train.n_points, settings.synthesis.to_dict(),
                    settings.train.to_dict(), metrics)
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
        held = replace(held, headings_deg=held.headings_deg[::3], tilts_deg=held.tilts_deg[1::2], copies=1)
    return synthesize_set(class_names, mesh_for, held, cache_dir, progress)
