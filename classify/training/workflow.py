"""The whole job behind ``auvlink train`` and ``auvlink eval``: synthesize from the object catalog,
train, evaluate on held-out synthesized clouds (other seed, headings, tilts and altitudes), save.
``extra_evals`` adds checks the caller owns, each stored in the metrics under its name (``auvlink train
--recon-eval``: clouds that recon reconstructs from simulated passes,
:func:`auvlink.evaluation.recon_eval.recon_metrics`; evaluation only, never training data). With clutter in the
synthesis (``clutter_clouds > 0``) the model gets a 9th output, ``clutter``, and its threshold is calibrated on the
validation split (:func:`calibrate_clutter`) and stored in the checkpoint. ``[train] members`` > 1: that many models
trained alike from seeds ``seed``, ``seed + 1``, ... on the same clouds, saved as one checkpoint whose inference
averages them (:mod:`classify.ensemble`); the clutter threshold is calibrated on the mean, over the first model's
validation split (the others trained on part of it: the threshold sits a little lower than it would on unseen
clouds).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from classify.checkpoint import load_checkpoint, save_checkpoint
from classify.errors import SynthesisError
from classify.infer import Classifier
from classify.labels import CLUTTER, with_clutter
from classify.pointnet import PointNet
from classify.training.config import TrainSettings
from classify.training.dataset import CloudSet, MeshSource, catalog_meshes, heldout_settings, synthesize_set
from classify.training.decision_fit import SurveyObjects, cloud_probabilities, decision_stage
from classify.training.evaluate import EvalReport
from classify.training.solid_tops import SHADOW_TOPS_SOURCE, solid_tops
from classify.training.survey_tuning import SurveyClouds, mixed_with_synthesized, tune_on_surveys
from classify.training.synthesis import SynthesisSettings
from classify.training.train import TrainResult, train

#: the share of clutter among the clusters recon hands the classifier, which weighs the two errors in the
#: threshold's choice (:func:`calibrate_clutter`): 12 of 273 first emissions (4 %) on 40 random surveys (draw seed
#: 4242), rounded up to 0.1 because rough seabeds hold nearly all of them
CLUTTER_SHARE = 0.1


@dataclass
class TrainOutcome:
    path: Path
    result: TrainResult
    heldout: EvalReport
    metrics: dict[str, Any]


def evaluate_classifier(clf: Classifier, data: CloudSet) -> EvalReport:
    """Classify every cloud of ``data`` through the inference path, with its decision rule (``clutter`` from
    the calibrated threshold); labels mapped by class name."""
    names = list(clf.class_names)
    true = np.array([names.index(data.class_names[k]) for k in data.labels])
    pred = [names.index(c) for c, _ in clf.decide(cloud_probabilities(clf, data))]
    return EvalReport.from_predictions(clf.class_names, true, pred)


def calibrate_clutter(clf: Classifier, data: CloudSet, share: float = CLUTTER_SHARE) -> dict[str, Any]:
    """The ``clutter`` threshold from the clouds of ``data`` (the validation split): the probability of clutter,
    on a 0.01 grid from 0.3 to 0.95, that makes the fewest errors among recon's clusters of which a fraction
    ``share`` is clutter: ``(1 - share) x`` (objects called clutter) ``+ share x`` (clutter not called clutter),
    as rates over the split (its own mix of classes does not weigh in); the lowest such threshold."""
    if clf.clutter_index is None:
        return {}
    prob = cloud_probabilities(clf, data)[:, clf.clutter_index].astype(np.float64)
    is_clutter = np.array([data.class_names[k] == CLUTTER for k in data.labels])
    objects, clutter = prob[~is_clutter], prob[is_clutter]
    grid = np.round(np.arange(0.30, 0.951, 0.01), 2)
    false = np.array([np.mean(objects >= t) if objects.size else 0.0 for t in grid])
    missed = np.array([np.mean(clutter < t) if clutter.size else 0.0 for t in grid])
    cost = (1.0 - share) * false + share * missed
    k = int(np.argmin(cost))
    return {"clutter_threshold": float(grid[k]), "clutter_share": share, "n_objects": int(objects.size),
            "n_clutter": int(clutter.size), "objects_called_clutter": float(false[k]),
            "clutter_recall": float(1.0 - missed[k])}


@dataclass
class SurveyStage:
    """The networks after the survey stage, the clouds whose validation split calibrates the clutter threshold, and
    the stage's metrics."""

    models: list[PointNet]
    calibration_set: CloudSet
    metrics: dict[str, Any]


def survey_stage(models: Sequence[PointNet], settings: TrainSettings, names: Sequence[str],
                 survey_clouds: SurveyClouds | None, synthesized: CloudSet | None = None,
                 progress: bool = True) -> SurveyStage:
    """``models`` trained on from their weights on the clouds of ``settings.surveys`` simulated surveys
    (:mod:`classify.training.survey_tuning`), with ``synthesized`` clouds (the synthesized training set) making up
    ``[surveys] synthesized_share`` of them; ``survey_clouds`` makes the survey clouds (the application layer's)."""
    s = settings.surveys
    if survey_clouds is None:
        raise SynthesisError(f"[surveys] surveys = {s.surveys} needs the clouds of simulated surveys: run "
                             "`auvlink train`, or set surveys = 0")
    if s.synthesized_share > 0 and synthesized is None:
        raise SynthesisError(f"[surveys] synthesized_share = {s.synthesized_share} needs the synthesized training "
                             "clouds: pass them, or set synthesized_share = 0")
    t0 = time.perf_counter()
    surveys = survey_clouds(s, tuple(names))
    t_clouds = time.perf_counter() - t0
    if len(surveys) < 2 * len(names):
        raise SynthesisError(f"{s.surveys} surveys gave {len(surveys)} clouds, too few for {len(names)} classes: "
                             "draw more ([surveys] surveys)")
    data, from_survey = mixed_with_synthesized(surveys, synthesized, s.synthesized_share, s.seed)
    tuned = tune_on_surveys(models, data, s, settings.train, progress)
    counts = np.bincount(surveys.labels, minlength=len(names))
    per_class = dict(zip(names, counts.tolist(), strict=True))
    metrics = {"settings": s.to_dict(), "n_clouds": len(surveys), "n_synthesized": int((~from_survey).sum()),
               "clouds_per_class": per_class, "clouds_seconds": t_clouds,
               "train_seconds": sum(r.seconds for r in tuned),
               "val_accuracy": [r.val_accuracy for r in tuned], "best_epoch": [r.best_epoch for r in tuned]}
    val = tuned[0].val_idx
    return SurveyStage([r.model for r in tuned], data.subset(val[from_survey[val]]), metrics)


def train_and_save(settings: TrainSettings, out: Path, cache_dir: Path | None = None, progress: bool = True,
                   meshes: tuple[tuple[str, ...], MeshSource] | None = None,
                   extra_evals: Mapping[str, Callable[[Classifier], dict[str, Any]]] | None = None,
                   survey_clouds: SurveyClouds | None = None,
                   survey_objects: SurveyObjects | None = None) -> TrainOutcome:
    names, mesh_for = meshes if meshes is not None else catalog_meshes()
    names = with_clutter(names, settings.synthesis.clutter_clouds > 0)
    t0 = time.perf_counter()
    data = synthesize_set(names, mesh_for, settings.synthesis, cache_dir, progress)
    t_syn = time.perf_counter() - t0
    result = train(data, settings.train, progress=progress)
    others = [train(data, replace(settings.train, seed=settings.train.seed + k), progress=progress)
              for k in range(1, max(1, settings.train.members))]
    members = [r.model for r in others]
    model = result.model
    held_settings = heldout_settings(settings.synthesis)
    held = synthesize_set(names, mesh_for, held_settings, cache_dir, progress)
    metrics: dict[str, Any] = {
        "synthesis_seconds": t_syn, "train_seconds": result.seconds + sum(r.seconds for r in others),
        "members": 1 + len(others), "best_epoch": result.best_epoch,
        "epochs_run": len(result.history), "val_accuracy": result.val_accuracy, "n_train_clouds": len(data),
        "history": result.history, "config_source": settings.source,
    }
    calibration_set = data.subset(result.val_idx)
    if settings.surveys.surveys > 0:
        stage = survey_stage([model, *members], settings, names, survey_clouds, data, progress)
        model, members, calibration_set = stage.models[0], stage.models[1:], stage.calibration_set
        metrics["surveys"] = stage.metrics

    def save(calibration: dict[str, Any] | None = None) -> Path:  # the metrics as they stand
        return save_checkpoint(out, model, names, settings.train.n_points, settings.synthesis.to_dict(),
                               settings.train.to_dict(), metrics, calibration, members)

    path = save()
    calibration = {**calibrate_clutter(Classifier.load(path), calibration_set),
                   "shadow_tops_m": solid_tops(names, mesh_for), "shadow_tops_source": SHADOW_TOPS_SOURCE}
    metrics["calibration"] = calibration
    path = save(calibration)
    if settings.decision.surveys > 0:
        calibration = with_decision(path, calibration, settings, survey_objects, metrics)
        path = save(calibration)
    clf = Classifier.load(path)  # as calibrated: what inference loads
    report = evaluate_classifier(clf, held)
    metrics["heldout"] = {"settings": held_settings.to_dict(), **report.to_dict()}
    for key, check in (extra_evals or {}).items():
        metrics[key] = check(clf)
    save(calibration)
    return TrainOutcome(path, result, report, metrics)


def with_decision(path: Path, calibration: dict[str, Any], settings: TrainSettings,
                  survey_objects: SurveyObjects | None, metrics: dict[str, Any]) -> dict[str, Any]:
    """``calibration`` with the decision model of the checkpoint at ``path`` (:mod:`classify.training.decision_fit`,
    ``[decision]``) fitted on ``survey_objects`` (the application layer's); the stage's metrics go into
    ``metrics["decision"]``."""
    if survey_objects is None:
        raise SynthesisError(f"[decision] surveys = {settings.decision.surveys} needs the objects of simulated "
                             "surveys: run `auvlink train`, or set [decision] surveys = 0")
    clf = Classifier.load(path)
    clf.decision = None  # the networks' own probabilities and rule, whatever the checkpoint held
    model, stage = decision_stage(clf, settings.decision, survey_objects)
    metrics["decision"] = stage
    return {**calibration, "decision": model.to_meta().model_dump()}


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
        held = replace(held, clutter_clouds=max(8, round(held.clutter_clouds * len(held.directions) / views)),
                       object_patch_views=min(held.object_patch_views, 2))
    return synthesize_set(class_names, mesh_for, held, cache_dir, progress)


def tune_checkpoint(checkpoint: Path, settings: TrainSettings, out: Path, survey_clouds: SurveyClouds,
                    cache_dir: Path | None = None, progress: bool = True,
                    mesh_for: MeshSource | None = None,
                    survey_objects: SurveyObjects | None = None) -> tuple[Path, dict[str, Any]]:
    """``auvlink train --from-checkpoint``: the survey stage alone on the networks of ``checkpoint`` (its classes,
    synthesis and training settings kept), its clutter threshold calibrated again on the survey clouds, and its
    held-out synthesized clouds (:func:`heldout_set`, thinned) classified again (the checkpoint's own held-out report
    kept as ``heldout_before_surveys``); saved to ``out`` (with its inference export). The synthesized clouds mixed
    in (``[surveys] synthesized_share``) are the checkpoint's own training set, synthesized from its settings
    (``mesh_for``: the catalogue's meshes unless given). Returns the path and the metrics saved with it."""
    ck = load_checkpoint(checkpoint)
    mesh_for = mesh_for or catalog_meshes()[1]
    synthesized = None
    if settings.surveys.synthesized_share > 0:  # the checkpoint's own training clouds (cached by their settings)
        synthesized = synthesize_set(ck.class_names, mesh_for, SynthesisSettings.from_dict(ck.synthesis), cache_dir,
                                     progress)
    stage = survey_stage([ck.model, *ck.members], settings, ck.class_names, survey_clouds, synthesized, progress)
    metrics = {**ck.metrics, "surveys": {**stage.metrics, "from_checkpoint": str(checkpoint)}}
    if "heldout" in ck.metrics:
        metrics["heldout_before_surveys"] = metrics.pop("heldout")
    metrics.pop("decision", None)
    models = stage.models

    def save(calibration: dict[str, Any]) -> Path:
        return save_checkpoint(out, models[0], ck.class_names, ck.n_points, ck.synthesis, ck.train, metrics,
                               calibration, models[1:])

    path = save(ck.calibration)
    clutter = calibrate_clutter(Classifier.load(path), stage.calibration_set)
    calibration = {k: v for k, v in ck.calibration.items() if k not in ("clutter_threshold_before", "decision")}
    calibration.update(clutter)
    metrics["calibration"] = calibration
    path = save(calibration)
    if settings.decision.surveys > 0:
        calibration = with_decision(path, calibration, settings, survey_objects, metrics)
        path = save(calibration)
    held = heldout_set(ck.synthesis, ck.class_names, cache_dir, progress=progress, mesh_for=mesh_for, thin=True)
    metrics["heldout"] = {"thin": True, **evaluate_classifier(Classifier.load(path), held).to_dict()}
    return save(calibration), metrics


def fit_checkpoint_decision(checkpoint: Path, settings: TrainSettings, out: Path,
                            survey_objects: SurveyObjects) -> tuple[Path, dict[str, Any]]:
    """``auvlink train --fit-decision``: the checkpoint's networks and calibration as they are, with a decision model
    (``[decision]``) fitted on their probabilities; saved to ``out`` (with its inference export). Returns the path and
    the decision stage's metrics."""
    if settings.decision.surveys <= 0:
        raise SynthesisError("--fit-decision needs [decision] surveys > 0 (or --decision-surveys N)")
    ck = load_checkpoint(checkpoint)
    metrics = dict(ck.metrics)
    calibration = {k: v for k, v in ck.calibration.items() if k != "decision"}
    calibration = with_decision(checkpoint, calibration, settings, survey_objects, metrics)
    metrics["calibration"] = calibration
    path = save_checkpoint(out, ck.model, ck.class_names, ck.n_points, ck.synthesis, ck.train, metrics, calibration,
                           ck.members)
    return path, metrics["decision"]
