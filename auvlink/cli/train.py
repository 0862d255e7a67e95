"""``auvlink train [--out MODEL.pt] [--config TOML] [--epochs N] [--seed N] [--quick] [--threads N]``.

Synthesizes training clouds from the object catalog (cached under ``--cache``), trains PointNet
with the settings of ``--config`` (default: the shipped ``classify/data/train_default.toml``),
evaluates on held-out synthesized clouds and writes the checkpoint (class names, synthesis
settings, model and training configuration, metrics), and its inference export beside it (``MODEL.npz``: the folded
weights and what inference reads, so that replay, live and batch runs classify with NumPy and never import PyTorch;
:mod:`classify.inference_export`). An existing ``--out`` (or its ``.npz``) is replaced only with ``--force``
(checked before any work); each file is written under a temporary name and renamed.

``auvlink train --shadow-tops MODEL.pt --out OUT.pt`` trains nothing: it writes a copy of the checkpoint whose
calibration holds the top heights of the catalogue's solid classes (:mod:`classify.training.solid_tops`), what
classification weighs each object's shadow height against (:mod:`classify.shadow_height`); training stores them
itself.

The survey stage (``[surveys] surveys`` > 0 in the settings, or ``--surveys N``): after the synthesized clouds, the
networks are trained on from their weights on the clouds recon makes of N simulated surveys drawn over the survey
and acoustic space (:mod:`classify.training.survey_tuning`, :mod:`auvlink.evaluation.survey_clouds`; cached per
survey; every ``ideal_every``-th under the idealized model), mixed with synthesized training clouds
(``synthesized_share``), and the clutter threshold is calibrated on the survey clouds of their validation split.
``auvlink train --from-checkpoint MODEL.pt --out OUT.pt`` runs that stage alone on an existing checkpoint's networks.

The decision stage (``[decision] surveys`` > 0, or ``--decision-surveys N``): once the networks are final, the
decision model over their probabilities and each object's evidence (shadow height and readings, extent, top, points,
time span; :mod:`classify.decision`) is fitted on the objects recon finalizes in N simulated surveys of their own
seed (:mod:`classify.training.decision_fit`; cached per survey). ``auvlink train --fit-decision MODEL.pt --out
OUT.pt`` fits it alone on an existing checkpoint; ``--from-checkpoint`` fits it after the survey stage.

``auvlink train --export-inference MODEL.pt`` trains nothing: it writes the inference export ``MODEL.npz`` of an
existing checkpoint (one saved before exports were written, or whose export is stale: made from another file of
that name). An existing ``MODEL.npz`` is replaced only with ``--force``.

The clutter threshold is first calibrated on held-out synthesized clouds. ``--calibrate-surveys N``
(``--calibrate-seed S``, default 2; ``--workers K``) then sets it where it acts: N random surveys are
simulated and replayed with the new model, every clutter threshold from 0.30 to 0.95 is scored
(:mod:`auvlink.evaluation.clutter_sweep`), and the checkpoint takes the best one by F1 at 1 m (the held-out value
is kept as ``clutter_threshold_before``). The surveys' folders go to ``--calibrate-out`` (default: a temporary
folder, removed). Keep the calibration seed apart from the seeds you evaluate the model on.

``--recon-eval`` adds the accuracy on clouds recon reconstructs from passes the simulator renders (idealized sonar);
``--recon-eval-acoustics PROFILE ...`` the same on the quick passes rendered under each sonar profile
(:func:`auvlink.evaluation.recon_eval.recon_metrics`; metrics ``recon_PROFILE``).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from auvlink.atomic import check_output_dir, check_output_file
from auvlink.cli.survey_options import check_survey_options
from auvlink.cli.train_stages import (
    fit_decision,
    from_checkpoint,
    print_decision,
    print_surveys,
    survey_clouds,
    survey_objects,
)
from auvlink.errors import AuvlinkError
from auvlink.sim.acoustics import PROFILES
from classify.inference_export import export_path, matching_export

if TYPE_CHECKING:
    from classify.training.survey_tuning import SurveySettings


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--export-inference", type=Path, default=None, metavar="MODEL.pt",
                   help="train nothing: write the inference export MODEL.npz of the existing checkpoint MODEL.pt "
                        "(an existing MODEL.npz only with --force)")
    p.add_argument("--shadow-tops", type=Path, default=None, metavar="MODEL.pt",
                   help="train nothing: write a copy of the checkpoint MODEL.pt to --out whose calibration holds the "
                        "top heights of the catalogue's solid classes (weighed against objects' shadow heights)")
    p.add_argument("--out", type=Path, default=Path("pointnet.pt"), help="checkpoint to write (default pointnet.pt)")
    p.add_argument("--force", action="store_true", help="replace an existing --out")
    p.add_argument("--config", type=Path, default=None,
                   help="training settings TOML (default: classify/data/train_default.toml)")
    p.add_argument("--epochs", type=int, default=None, help="override the number of epochs")
    p.add_argument("--seed", type=int, default=None, help="override the training seed")
    p.add_argument("--quick", action="store_true", help="reduced budget (the [quick] table of the settings)")
    p.add_argument("--threads", type=int, default=None, help="override the number of torch CPU threads")
    p.add_argument("--cache", type=Path, default=None,
                   help="folder for synthesized clouds (default $AUVLINK_CACHE/classify or ~/.cache/auvlink/classify)")
    p.add_argument("--no-cache", action="store_true", help="synthesize afresh and keep nothing on disk")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.add_argument("--recon-eval", action="store_true",
                   help="also evaluate on clouds recon reconstructs from simulated passes (stored in the metrics)")
    p.add_argument("--recon-eval-acoustics", nargs="+", default=(), choices=PROFILES[1:], metavar="PROFILE",
                   help=f"also evaluate on recon's clouds of passes rendered under these sonar profiles "
                        f"({', '.join(PROFILES[1:])}; the quick passes, stored as recon_PROFILE in the metrics)")
    p.add_argument("--calibrate-surveys", type=int, default=None, metavar="N",
                   help="set the clutter threshold from N random simulated surveys (best F1 at 1 m)")
    p.add_argument("--calibrate-seed", type=int, default=2, metavar="S",
                   help="draw seed of the calibration surveys (default 2; keep it apart from evaluation seeds)")
    p.add_argument("--calibrate-out", type=Path, default=None, metavar="DIR",
                   help="keep the calibration surveys' results in DIR (new or empty unless --force)")
    p.add_argument("--workers", type=int, default=2, help="--calibrate-surveys: worker processes (default 2)")
    p.add_argument("--surveys", type=int, default=None, metavar="N",
                   help="override [surveys] surveys: the simulated surveys whose recon clouds the networks are trained "
                        "on after the synthesized clouds (0: none)")
    p.add_argument("--decision-surveys", type=int, default=None, metavar="N",
                   help="override [decision] surveys: the simulated surveys whose objects fit the decision model "
                        "over the networks' probabilities and each object's evidence (0: none)")
    p.add_argument("--fit-decision", type=Path, default=None, metavar="MODEL.pt",
                   help="train no network: fit the decision model ([decision]) on the networks of MODEL.pt and "
                        "write the result to --out")
    p.add_argument("--from-checkpoint", type=Path, default=None, metavar="MODEL.pt",
                   help="synthesize and train nothing first: run the survey stage on the networks of MODEL.pt and "
                        "write the result to --out (its clutter threshold calibrated again)")


def run(args: argparse.Namespace) -> int:
    if args.export_inference is not None:
        return _export(args.export_inference, args.force)
    if args.shadow_tops is not None:
        return _shadow_tops(args.shadow_tops, args.out, args.force)
    check_output_file(args.out, force=args.force, inputs=[args.config, args.fit_decision],
                      what="checkpoint")  # before torch loads
    check_output_file(export_path(args.out), force=args.force, inputs=[args.config], what="inference export")
    if args.calibrate_surveys is not None:
        check_survey_options(("--calibrate-surveys", args.calibrate_surveys), ("--calibrate-seed", args.calibrate_seed),
                             args.workers)
        if args.calibrate_out is not None:
            check_output_dir(args.calibrate_out, force=args.force, option="--calibrate-out")
    # lazy: PyTorch and Open3D load only for this command (the parser imports every subcommand module)
    from auvlink.evaluation.recon_eval import recon_metrics
    from classify.training.config import load_train_settings, with_overrides
    from classify.training.dataset import default_cache_dir
    from classify.training.workflow import train_and_save

    settings = with_overrides(load_train_settings(args.config, quick=args.quick), args.epochs, args.seed,
                              args.threads, args.surveys, args.decision_surveys)
    _check_surveys(settings.surveys)
    cache = None if args.no_cache else (args.cache or default_cache_dir())
    if args.from_checkpoint is not None:
        return from_checkpoint(args, settings, cache)
    if args.fit_decision is not None:
        return fit_decision(args, settings, cache)
    extra = {"recon": recon_metrics(cache, progress=not args.quiet)} if args.recon_eval else {}
    extra.update({f"recon_{p}": recon_metrics(cache, not args.quiet, p, quick=True) for p in args.recon_eval_acoustics})
    out = train_and_save(settings, args.out, cache, progress=not args.quiet, extra_evals=extra,
                         survey_clouds=survey_clouds(settings.synthesis, cache, not args.quiet),
                         survey_objects=survey_objects(settings.synthesis, cache, not args.quiet))
    m = out.metrics
    print(f"trained {m['epochs_run']} epochs in {m['train_seconds']:.1f} s (synthesis {m['synthesis_seconds']:.1f} s), "
          f"best epoch {m['best_epoch']}, validation accuracy {m['val_accuracy']:.3f}")
    if "surveys" in m:
        print_surveys(m["surveys"])
    if "decision" in m:
        print_decision(m["decision"])
    print(f"held-out synthesized clouds ({out.heldout.n}):")
    print(out.heldout.text())
    for key in ("recon", *(f"recon_{p}" for p in args.recon_eval_acoustics)):
        if key in m:
            r = m[key]
            print(f"{key}: recon clouds of simulated passes ({r['n']} detected of {r['n_passes']}): accuracy "
                  f"{r['accuracy']:.3f}, macro precision {r['macro']['precision']:.3f}, "
                  f"recall {r['macro']['recall']:.3f}")
    if args.calibrate_surveys is not None:
        _calibrate(args, out.path)
    print(f"checkpoint: {out.path} ({out.path.stat().st_size / 1e6:.2f} MB)")
    return 0


def _check_surveys(s: SurveySettings) -> None:
    """A ``[surveys]`` acoustic space and sonar that cannot go together, refused before any work."""
    from auvlink.evaluation.acoustic_draw import check_pairing

    try:
        check_pairing(s.acoustics, s.sonar)
    except ValueError as exc:
        raise AuvlinkError(f"[surveys] acoustics = {s.acoustics!r} with sonar = {s.sonar!r}: {exc}") from exc


def _calibrate(args: argparse.Namespace, model: Path) -> None:
    """Set ``model``'s clutter threshold from a sweep over ``args.calibrate_surveys`` simulated surveys."""
    from auvlink.evaluation.clutter_sweep import table
    from auvlink.evaluation.surveys import calibrate_model

    seed = args.calibrate_seed
    cs = calibrate_model(model, args.calibrate_surveys, seed, args.calibrate_out, workers=args.workers,
                         progress=not args.quiet)
    print(f"clutter threshold on {cs['surveys']} calibration surveys (seed {seed}; 1 m, class must match):")
    print(table(cs["rows"], cs["model_threshold"], cs["best"]))
    print(f"clutter threshold {cs['model_threshold']:.2f} (held-out clouds) -> {cs['best']:.2f} (surveys)")


def _shadow_tops(checkpoint: Path, out: Path, force: bool) -> int:
    """Write ``checkpoint``'s copy with the solid classes' top heights to ``out`` (see the module doc)."""
    if not checkpoint.is_file():
        raise AuvlinkError(f"--shadow-tops {checkpoint}: no such checkpoint")
    check_output_file(out, force=force, inputs=[checkpoint], option="--out", what="checkpoint")
    check_output_file(export_path(out), force=force, option="--out", what="inference export")
    from classify.training.dataset import catalog_meshes  # lazy: PyTorch and the meshes load only for this command
    from classify.training.solid_tops import write_solid_tops

    path = write_solid_tops(checkpoint, out, catalog_meshes()[1])
    from classify.checkpoint import load_checkpoint

    print(f"checkpoint: {path}; solid classes' tops (m): {load_checkpoint(path).calibration['shadow_tops_m']}")
    return 0


def _export(checkpoint: Path, force: bool) -> int:
    """Write the inference export of ``checkpoint`` beside it (see the module doc)."""
    if not checkpoint.is_file():
        raise AuvlinkError(f"--export-inference {checkpoint}: no such checkpoint")
    out = export_path(checkpoint)
    if matching_export(checkpoint)[0] is not None and not force:
        print(f"inference export: {out} (already made from this checkpoint)")
        return 0
    check_output_file(out, force=force, inputs=[checkpoint], option="--export-inference", what="inference export")
    from classify.checkpoint import export_checkpoint  # lazy: PyTorch loads only for this command

    export_checkpoint(checkpoint)
    print(f"inference export: {out} ({out.stat().st_size / 1e6:.2f} MB)")
    return 0
