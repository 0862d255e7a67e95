"""classify.training: the clouds the classifier learns from, training, and its evaluation.

Imports the simulator (:mod:`auvlink.sim`), recon and, lazily, Open3D; a vehicle running the classifier needs none
of it (:mod:`classify` is the runtime). Modules:

Training data:

- :mod:`classify.training.synthesis_settings`: :class:`~classify.training.synthesis_settings.SynthesisSettings`,
  shared by both modes.
- :mod:`classify.training.synthesis` (mode ``paper``: Sung et al.'s back-face culling, hidden-surface removal,
  front slope) and :mod:`classify.training.scan_synth` (mode ``scan``, the shipped model's: a simulated pass over
  the mesh, reduced to what recon's highlight extension and front-slope correction make of it).
- :mod:`classify.training.views`: single, fused and partial views as recon hands them over.
- :mod:`classify.training.seabed_returns`: the ray model of a line over the simulator's rough seabed (and an
  object); :mod:`classify.training.clutter_synth` (clusters recon makes of a rough seabed, the class ``clutter``)
  and :mod:`classify.training.object_patch_synth` (objects on rough patches through recon's own seabed removal).
- :mod:`classify.training.dataset`: :class:`~classify.training.dataset.CloudSet`,
  :func:`~classify.training.dataset.synthesize_set` over the object catalog with an on-disk cache, held-out
  settings, stratified splits.

Training and evaluation:

- :mod:`classify.training.config` (training settings TOML, default ``classify/data/train_default.toml``),
  :mod:`classify.training.augment`, :mod:`classify.training.train`, :mod:`classify.training.workflow` (what
  ``auvlink train`` / ``auvlink eval`` run, the clutter threshold's calibration).
- :mod:`classify.training.evaluate`: precision, recall, F1, confusion matrix and its PNG, look-alike pairs.
- :mod:`classify.training.baseline2d`, :mod:`classify.training.baseline_images`,
  :mod:`classify.training.baseline_eval`: the single-image 2D CNN baseline on simulated sonar images.

The classifier on clouds recon reconstructs from simulated passes, and on whole simulated surveys, is evaluation, in
the application layer: :mod:`auvlink.evaluation.recon_eval`, :mod:`auvlink.evaluation.surveys`.

Files touched: synthesized-cloud caches, checkpoints and the evaluation's PNG/JSON outputs; no ports.
"""
