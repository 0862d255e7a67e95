"""classify: name the objects recon finds, with PointNet trained on clouds synthesized from meshes.

Modules (import what you use; torch loads only with the model modules):

Inference (what a vehicle runs):

- :mod:`classify.infer`: :class:`~classify.infer.Classifier` (``Classifier.load(path)``; ``probabilities`` of
  clouds as 4 yaw views averaged, ``decide`` the class or ``clutter``; ``classify`` one cloud).
- :mod:`classify.pointnet`: :class:`~classify.pointnet.PointNet` (width multiplier, BN folding);
  :mod:`classify.ensemble`: several seeds' models read as one.
- :mod:`classify.checkpoint`: one file of weights and plain metadata (calibration, members).
- :mod:`classify.normalize`: a cloud in metres -> the network's input (unit sphere, or height above the seabed).
- :mod:`classify.labels`: ``clutter`` beside the object catalogue's classes; :mod:`classify.errors`.

Training data:

- :mod:`classify.synthesis_settings`: :class:`~classify.synthesis_settings.SynthesisSettings`, shared by both modes.
- :mod:`classify.synthesis` (mode ``paper``: Sung et al.'s back-face culling, hidden-surface removal, front slope)
  and :mod:`classify.scan_synth` (mode ``scan``, the shipped model's: a simulated pass over the mesh, reduced to
  what recon's highlight extension and front-slope correction make of it).
- :mod:`classify.views`: single, fused and partial views as recon hands them over.
- :mod:`classify.seabed_returns`: the ray model of a line over the simulator's rough seabed (and an object);
  :mod:`classify.clutter_synth` (clusters recon makes of a rough seabed, the class ``clutter``) and
  :mod:`classify.object_patch_synth` (objects on rough patches through recon's own seabed removal).
- :mod:`classify.dataset`: :class:`~classify.dataset.CloudSet`, :func:`~classify.dataset.synthesize_set` over
  the object catalog with an on-disk cache, held-out settings, stratified splits.

Training and evaluation:

- :mod:`classify.config` (training settings TOML), :mod:`classify.augment`, :mod:`classify.train`,
  :mod:`classify.workflow` (what ``auvlink train`` / ``auvlink eval`` run, the clutter threshold's calibration).
- :mod:`classify.evaluate`: precision, recall, F1, confusion matrix and its PNG, look-alike pairs.
- :mod:`classify.baseline2d`, :mod:`classify.baseline_images`, :mod:`classify.baseline_eval`: the
  single-image 2D CNN baseline on simulated sonar images.

The classifier on clouds recon reconstructs from simulated passes, and on whole simulated surveys, is evaluation, in
the application layer: :mod:`auvlink.evaluation.recon_eval`, :mod:`auvlink.evaluation.surveys`.

Files touched: synthesized-cloud caches and checkpoints only; no ports.
"""
