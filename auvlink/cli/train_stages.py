"""The stages of ``auvlink train`` that fly simulated surveys: what makes their clouds and objects, the survey stage
alone on a checkpoint (``--from-checkpoint``), the decision model alone (``--fit-decision``), and their summaries.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from auvlink.atomic import check_output_file
from auvlink.errors import AuvlinkError
from classify.inference_export import export_path

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

    from classify.training.config import TrainSettings
    from classify.training.dataset import CloudSet
    from classify.training.decision_fit import DecisionSettings, SurveyObjects
    from classify.training.survey_tuning import SurveyClouds, SurveySettings
    from classify.training.synthesis import SynthesisSettings


def survey_clouds(synthesis: SynthesisSettings, cache: Path | None, progress: bool) -> SurveyClouds:
    """What makes the survey stage's clouds (:func:`auvlink.evaluation.survey_clouds.survey_cloud_set`), normalized
    as ``synthesis``'s clouds, cached under ``cache`` (None: nothing kept)."""
    from auvlink.evaluation.survey_clouds import survey_cloud_set

    def make(s: SurveySettings, names: Sequence[str]) -> CloudSet:
        return survey_cloud_set(s.surveys, s.seed, names, n_points=synthesis.n_points, scale_m=synthesis.scale_m,
                                z_ref=synthesis.z_ref, cache_dir=cache, workers=s.workers, progress=progress,
                                acoustics=s.acoustics, sonar=s.sonar, ideal_every=s.ideal_every)
    return make


def survey_objects(synthesis: SynthesisSettings, cache: Path | None, progress: bool) -> SurveyObjects:
    """What makes the decision stage's objects (:func:`auvlink.evaluation.survey_clouds.survey_object_set`): their
    clouds normalized as ``synthesis``'s and their evidence, cached under ``cache`` (None: nothing kept)."""
    from auvlink.evaluation.survey_clouds import survey_object_set

    def make(s: DecisionSettings, names: Sequence[str]) -> tuple[CloudSet, npt.NDArray[np.float64]]:
        return survey_object_set(s.surveys, s.seed, names, n_points=synthesis.n_points, scale_m=synthesis.scale_m,
                                 z_ref=synthesis.z_ref, cache_dir=cache, workers=s.workers, progress=progress,
                                 acoustics=s.acoustics, sonar=s.sonar, ideal_every=s.ideal_every)
    return make


def print_surveys(m: dict[str, Any]) -> None:
    s = m["settings"]
    ideal = f", 1 in {s['ideal_every']} ideal" if s.get("ideal_every") else ""
    print(f"survey stage: {m['n_clouds']} clouds of {s['surveys']} surveys (seed {s['seed']}, acoustics "
          f"{s['acoustics']}{ideal}, sonar {s['sonar']}) in {m['clouds_seconds']:.0f} s and "
          f"{m.get('n_synthesized', 0)} synthesized, trained {m['train_seconds']:.0f} s; "
          f"validation accuracy {', '.join(f'{a:.3f}' for a in m['val_accuracy'])}")


def print_decision(m: dict[str, Any]) -> None:
    s = m["settings"]
    ideal = f", 1 in {s['ideal_every']} ideal" if s.get("ideal_every") else ""
    line = (f"decision model: {m['n_objects']} objects of {s['surveys']} surveys (seed {s['seed']}, acoustics "
            f"{s['acoustics']}{ideal}, sonar {s['sonar']})")
    h = m.get("holdout")
    if h:
        a, b = h["network_rule"], h["decision"]
        line += (f"; on {h['n_objects']} held-out objects, objects named right {a['object_recall']:.3f} -> "
                 f"{b['object_recall']:.3f}, reported named right {a['reported_precision']:.3f} -> "
                 f"{b['reported_precision']:.3f}")
    print(line)


def _synthesis_of(checkpoint: Path, option: str, surveys: int, needs: str) -> SynthesisSettings:
    """The synthesis settings of ``checkpoint`` (what its clouds are normalized by), once it exists and the stage
    ``option`` runs has ``surveys`` to fly (else :class:`AuvlinkError`: ``option`` ``needs``)."""
    if not checkpoint.is_file():
        raise AuvlinkError(f"{option} {checkpoint}: no such checkpoint")
    if surveys <= 0:
        raise AuvlinkError(f"{option} {needs}")
    from classify.checkpoint import load_checkpoint
    from classify.training.synthesis import SynthesisSettings

    return SynthesisSettings.from_dict(load_checkpoint(checkpoint).synthesis)


def from_checkpoint(args: argparse.Namespace, settings: TrainSettings, cache: Path | None) -> int:
    """``--from-checkpoint``: the survey stage alone (see the module doc)."""
    checkpoint = args.from_checkpoint
    synthesis = _synthesis_of(checkpoint, "--from-checkpoint", settings.surveys.surveys,
                              "runs the survey stage: give it surveys (--surveys N or [surveys] surveys in --config)")
    from classify.training.workflow import tune_checkpoint

    path, m = tune_checkpoint(checkpoint, settings, args.out, survey_clouds(synthesis, cache, not args.quiet),
                              cache, progress=not args.quiet,
                              survey_objects=survey_objects(synthesis, cache, not args.quiet))
    print_surveys(m["surveys"])
    if "decision" in m:
        print_decision(m["decision"])
    print(f"clutter threshold {m['calibration'].get('clutter_threshold')} (survey clouds' validation split); "
          f"held-out synthesized clouds (thinned, {m['heldout']['n']}): accuracy {m['heldout']['accuracy']:.3f}")
    print(f"checkpoint: {path} ({path.stat().st_size / 1e6:.2f} MB)")
    return 0


def fit_decision(args: argparse.Namespace, settings: TrainSettings, cache: Path | None) -> int:
    """``--fit-decision MODEL.pt``: the decision model alone on a checkpoint (:mod:`classify.decision`)."""
    checkpoint = args.fit_decision
    check_output_file(args.out, force=args.force, inputs=[checkpoint], option="--out", what="checkpoint")
    check_output_file(export_path(args.out), force=args.force, option="--out", what="inference export")
    synthesis = _synthesis_of(checkpoint, "--fit-decision", settings.decision.surveys,
                              "fits the decision model on simulated surveys: give it surveys (--decision-surveys N "
                              "or [decision] surveys in --config)")
    from classify.training.workflow import fit_checkpoint_decision

    path, m = fit_checkpoint_decision(checkpoint, settings, args.out, survey_objects(synthesis, cache, not args.quiet))
    print_decision(m)
    print(f"checkpoint: {path} ({path.stat().st_size / 1e6:.2f} MB)")
    return 0
