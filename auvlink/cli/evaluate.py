"""``auvlink eval --model MODEL.pt [--out DIR] [--seed N]``: evaluate a classifier checkpoint.

Synthesizes held-out clouds for the checkpoint's synthesis settings (headings shifted by half a
step, tilts between the training tilts, a wider altitude range, another seed), classifies them
through the inference path and writes ``DIR/eval.json`` (precision, recall, F1 per class,
confusion matrix, look-alike pair confusions) and ``DIR/confusion.png``.

``--recon``: evaluate instead on clouds that recon reconstructs from simulated passes over single
objects (:mod:`auvlink.evaluation.recon_eval`: 8 headings x 2 tilts x 2 altitudes x 2 lateral offsets per
class, seed 11; with ``--quick`` 3 headings x 1 tilt x 2 altitudes), cached under ``--cache``.

``--surveys N [--seed S] [--workers K] [--json] [--keep-logs]``: instead, draw N random surveys
from the condition space (:mod:`auvlink.evaluation.draw`), simulate each into a log, replay it
through the pipeline and score the detections (1 m and 2 m, the class must match) overall, per
factor bin and by failure kind (:mod:`auvlink.evaluation.surveys`); writes ``DIR/surveys.json``
and ``DIR/surveys.png`` and prints the table, then per true class its recall, failures and what its wrongly classified
objects were called (``--json``: the pooled figures as JSON). Default seed 1. ``--acoustics SPACE``: the
acoustic conditions drawn with each survey (:mod:`auvlink.evaluation.acoustic_draw`): ``ideal`` (the default for
now, so figures stay comparable with earlier runs), ``random`` (profile, beam patterns, sidelobes, pulse, gain,
TVG error, noise floor, interference drawn over the profile of each survey's sonar model; one factor row each) or
a sonar profile name (with ``--surveys`` only for that profile's own ``--sonar``: another is refused before any
work); with ``--recon`` the passes are rendered under that profile. ``--sonar MODEL``: the sonar model flown
(:func:`auvlink.evaluation.draw.survey_sonar`; ``random``: one simulated model per survey).

``--clutter-sweep`` (with ``--surveys``): also measure the clutter threshold on those surveys
(:mod:`auvlink.evaluation.clutter_sweep`): the figures above stay those of the model's own threshold, and a table
gives precision, recall and F1 at every threshold from 0.30 to 0.95, the best marked (``clutter_sweep`` in
``surveys.json``, and in the ``--json`` output). ``--calibrated-model OUT.pt`` (implies ``--clutter-sweep``):
write a copy of the model with the best threshold, and its inference export ``OUT.npz`` (existing files only with
``--force``).

``--baseline2d``: also train and evaluate the paper's single-image baseline (a small 2D CNN on
simulated sonar images of the same objects, viewing heading varied; :mod:`classify.training.baseline_eval`)
and write ``DIR/baseline2d.json`` and ``DIR/baseline2d_confusion.png`` beside the PointNet figures.

DIR must be new or empty unless ``--force`` (checked before any work); each file is written under a
temporary name and renamed when whole.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import TYPE_CHECKING

from auvlink.atomic import check_output_dir, check_output_file, write_text
from auvlink.cli.survey_options import check_survey_options
from auvlink.errors import AuvlinkError
from auvlink.evaluation.acoustic_draw import SPACES, check_pairing
from auvlink.jsonutil import to_jsonable
from auvlink.pipeline.run_guard import output_dir_lock, refuse_input_overwrite
from auvlink.sim.scene import SIMULATED_MODELS

if TYPE_CHECKING:
    from classify.training.evaluate import EvalReport


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--model", type=Path, default=None, help="checkpoint (default: the shipped model)")
    p.add_argument("--out", type=Path, default=Path("eval-out"), help="output folder (default eval-out)")
    p.add_argument("--seed", type=int, default=None,
                   help="seed of the held-out synthesis (default training seed + 1000)")
    p.add_argument("--cache", type=Path, default=None, help="folder for synthesized clouds")
    p.add_argument("--no-cache", action="store_true", help="keep nothing on disk")
    p.add_argument("--quick", action="store_true", help="a thinner held-out set (every 3rd heading, 2 tilts, 1 draw)")
    p.add_argument("--recon", action="store_true",
                   help="evaluate on clouds recon reconstructs from simulated passes (not synthesized clouds)")
    p.add_argument("--surveys", type=int, default=None, metavar="N",
                   help="evaluate the whole pipeline on N random surveys (simulate, replay, score)")
    p.add_argument("--workers", type=int, default=2, help="--surveys: worker processes (default 2)")
    p.add_argument("--json", action="store_true", help="--surveys: print the pooled figures as JSON")
    p.add_argument("--small", action="store_true", help="--surveys: 2 lines and 2 objects each (CI smoke)")
    p.add_argument("--keep-logs", action="store_true", help="--surveys: keep each survey's mission.mcap")
    p.add_argument("--acoustics", choices=SPACES, default="random", metavar="SPACE",
                   help="--surveys: acoustic conditions per survey: random (default: the whole acoustic space over "
                        "each survey's sonar model's profile), ideal (the idealized model: hard beam edge, no "
                        f"sidelobes, fixed gain) or a fixed sonar profile ({', '.join(SPACES[2:])}: with its own "
                        "--sonar model only)")
    p.add_argument("--sonar", choices=(*SIMULATED_MODELS, "random"), default="didson",
                   help="--surveys: the sonar model flown (random: one per survey; default didson)")
    p.add_argument("--clutter-sweep", action="store_true",
                   help="--surveys: also score every clutter threshold from 0.30 to 0.95 on those surveys")
    p.add_argument("--calibrated-model", type=Path, default=None, metavar="OUT.pt",
                   help="--surveys: write a copy of the model with the best clutter threshold of the sweep")
    p.add_argument("--baseline2d", action="store_true",
                   help="also train and evaluate the single-image 2D CNN baseline (a few minutes)")
    p.add_argument("--force", action="store_true", help="write into a non-empty DIR (files of the same names replaced)")


#: what eval writes in DIR (held-out: eval.json and its figure, the 2D baseline's; --surveys: surveys/ and the pool)
EVAL_OUTPUTS = frozenset({"eval.json", "confusion.png", "baseline2d.json", "baseline2d_confusion.png", "surveys",
                          "surveys.json", "surveys.png"})


def run(args: argparse.Namespace) -> int:
    check_survey_options(("--surveys", args.surveys), ("--seed", args.seed), args.workers)  # before any work
    if args.surveys is not None:
        try:
            check_pairing(args.acoustics, args.sonar)
        except ValueError as exc:
            raise AuvlinkError(str(exc)) from exc
    refuse_input_overwrite([args.model], folder=("--out", args.out),
                           writes=lambda rel: rel.parts[0] in EVAL_OUTPUTS)
    with output_dir_lock(args.out, force=args.force):  # DIR is this run's until it ends
        return _surveys(args) if args.surveys is not None else _held_out(args)


def _held_out(args: argparse.Namespace) -> int:
    # lazy: PyTorch, Open3D and SciPy load only for this command (the parser imports every subcommand module)
    from auvlink.evaluation.recon_eval import evaluate_recon, reconstruct_set, standard_passes

    if args.recon and args.acoustics == "random":
        raise AuvlinkError(f"--acoustics random: --recon renders its passes under one sonar profile; "
                           f"name one of {', '.join(SPACES[1:])}")
    check_output_dir(args.out, force=args.force)  # before any work (and before torch loads)
    if args.model is not None:
        for name in ("eval.json", "confusion.png", "baseline2d.json", "baseline2d_confusion.png"):
            check_output_file(args.out / name, force=True, inputs=[args.model], what="result")
    from classify.infer import Classifier
    from classify.training.dataset import default_cache_dir
    from classify.training.evaluate import plot_confusion
    from classify.training.workflow import evaluate_classifier, heldout_set

    clf = Classifier.load(args.model)
    cache = None if args.no_cache else (args.cache or default_cache_dir())
    extra: dict[str, object] = {}
    if args.recon:
        passes = standard_passes(args.quick, args.acoustics)
        clouds = reconstruct_set(clf.object_classes, passes, progress=True, cache_dir=cache)
        report, missed = evaluate_recon(clf, clouds)
        extra = {"source": "recon clouds of simulated passes", "acoustics": passes.acoustics, "passes": len(clouds),
                 "not_detected": missed}
        title = f"recon clouds (n={report.n}, {missed} passes without a detection)"
    else:
        data = heldout_set(clf.checkpoint.synthesis, clf.class_names, cache, args.seed, progress=True,
                           thin=args.quick)
        report = evaluate_classifier(clf, data)
        extra = {"source": "held-out synthesized clouds"}
        title = f"held-out synthesized clouds (n={report.n})"
    args.out.mkdir(parents=True, exist_ok=True)
    result = {"model": str(args.model or "default"), "n_points": clf.n_points, **extra, **report.to_dict()}
    write_text(args.out / "eval.json", json.dumps(to_jsonable(result), indent=2, allow_nan=False) + "\n")
    png = plot_confusion(report, args.out / "confusion.png", title=title)
    print(report.text())
    print(f"written: {args.out / 'eval.json'}, {png}")
    if args.baseline2d:
        _baseline(args, clf.object_classes, cache, report)
    return 0


def _baseline(args: argparse.Namespace, class_names: tuple[str, ...], cache: Path | None, pointnet: EvalReport) -> None:
    # lazy: PyTorch and Open3D load only for this command (the parser imports every subcommand module)
    from classify.training.baseline2d import CNNConfig
    from classify.training.baseline_eval import run_baseline2d
    from classify.training.baseline_images import ImageSettings
    from classify.training.evaluate import plot_confusion

    out = run_baseline2d(class_names, ImageSettings(), CNNConfig(), cache, progress=True)
    rep = out.report
    result = {"source": "single simulated sonar images (held-out headings, tilts, altitudes)", "n_train": out.n_train,
              "render_seconds": out.render_seconds, "train_seconds": out.result.seconds, **rep.to_dict()}
    write_text(args.out / "baseline2d.json", json.dumps(to_jsonable(result), indent=2, allow_nan=False) + "\n")
    png = plot_confusion(rep, args.out / "baseline2d_confusion.png", title=f"2D CNN, single images (n={rep.n})")
    print("\n2D baseline (one sonar image per object):")
    print(rep.text())
    pn = pointnet.macro()
    print(f"PointNet above: macro precision {pn['precision']:.3f}, recall {pn['recall']:.3f}; 2D baseline: "
          f"{rep.macro()['precision']:.3f}, {rep.macro()['recall']:.3f}")
    print(f"written: {args.out / 'baseline2d.json'}, {png}")


def _surveys(args: argparse.Namespace) -> int:
    from auvlink.evaluation.surveys import run_surveys
    from auvlink.evaluation.tables import class_table, interval_line, plot, text_table
    from auvlink.jsonutil import to_jsonable

    check_output_dir(args.out, force=args.force)  # the surveys' folders of an earlier run are replaced
    calibrated = args.calibrated_model
    if calibrated is not None:
        from classify.infer import DEFAULT_MODEL
        from classify.inference_export import export_path

        check_output_file(calibrated, force=args.force, inputs=[args.model or DEFAULT_MODEL],
                          option="--calibrated-model", what="checkpoint")
        check_output_file(export_path(calibrated), force=args.force, inputs=[args.model or DEFAULT_MODEL],
                          option="--calibrated-model", what="inference export")
    seed = 1 if args.seed is None else args.seed
    result = run_surveys(args.surveys, seed, args.out, workers=args.workers, model=args.model,
                         keep_logs=args.keep_logs, progress=not args.json,
                         small=args.small, clutter_sweep=args.clutter_sweep or calibrated is not None,
                         acoustics=args.acoustics, sonar=args.sonar)
    png = plot(result, args.out / "surveys.png")
    if args.json:
        keys = ("seed", "command", "overall", "by_factor", "by_class", "clutter_sweep")
        print(json.dumps(to_jsonable({k: result[k] for k in keys if k in result})))
    else:
        print(text_table(result))
        print(interval_line(result))
        print("\nper true class (1 m, class must match):")
        print(class_table(result))
        print(f"written: {args.out / 'surveys.json'}, {png}")
    cs = result.get("clutter_sweep")
    if cs is not None:
        from auvlink.evaluation.clutter_sweep import table, write_calibrated

        if not args.json:
            print(f"\nclutter threshold on these {len(result['surveys'])} surveys (1 m, class must match):")
            print(table(cs["rows"], cs["model_threshold"], cs["best"]))
        if calibrated is not None:
            source = (f"auvlink eval --surveys {args.surveys} --seed {seed} --clutter-sweep: best F1 at 1 m, "
                      f"{len(result['surveys'])} surveys")
            path = write_calibrated(args.model, calibrated, cs["best"], source)
            if not args.json:
                print(f"written: {path} (clutter threshold {cs['model_threshold']:.2f} -> {cs['best']:.2f})")
    return 0
