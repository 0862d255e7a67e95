"""``auvlink train [--out MODEL.pt] [--config TOML] [--epochs N] [--seed N] [--quick] [--threads N]``.

Synthesizes training clouds from the object catalog (cached under ``--cache``), trains PointNet
with the settings of ``--config`` (default: the shipped ``classify/data/train_default.toml``),
evaluates on held-out synthesized clouds and writes the checkpoint (class names, synthesis
settings, model and training configuration, metrics). An existing ``--out`` is replaced only with
``--force`` (checked before any work); the checkpoint is written under a temporary name and renamed.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from auvlink.atomic import check_output_file


def add_arguments(p: argparse.ArgumentParser) -> None:
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


def run(args: argparse.Namespace) -> int:
    check_output_file(args.out, force=args.force, inputs=[args.config], what="checkpoint")  # before torch loads
    # lazy: PyTorch and Open3D load only for this command (the parser imports every subcommand module)
    from auvlink.evaluation.recon_eval import recon_metrics
    from classify.config import load_train_settings, with_overrides
    from classify.dataset import default_cache_dir
    from classify.workflow import train_and_save

    settings = with_overrides(load_train_settings(args.config, quick=args.quick), args.epochs, args.seed,
                              args.threads)
    cache = None if args.no_cache else (args.cache or default_cache_dir())
    extra = {"recon": recon_metrics(cache, progress=not args.quiet)} if args.recon_eval else None
    out = train_and_save(settings, args.out, cache, progress=not args.quiet, extra_evals=extra)
    m = out.metrics
    print(f"trained {m['epochs_run']} epochs in {m['train_seconds']:.1f} s (synthesis {m['synthesis_seconds']:.1f} s), "
          f"best epoch {m['best_epoch']}, validation accuracy {m['val_accuracy']:.3f}")
    print(f"held-out synthesized clouds ({out.heldout.n}):")
    print(out.heldout.text())
    if "recon" in m:
        r = m["recon"]
        print(f"recon clouds of simulated passes ({r['n']} detected of {r['n_passes']}): accuracy {r['accuracy']:.3f}, "
              f"macro precision {r['macro']['precision']:.3f}, recall {r['macro']['recall']:.3f}")
    print(f"checkpoint: {out.path} ({out.path.stat().st_size / 1e6:.2f} MB)")
    return 0
