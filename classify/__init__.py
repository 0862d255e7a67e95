"""classify: name the objects recon finds, with PointNet trained on clouds synthesized from meshes.

Modules (import what you use; torch loads only with the model modules):

- :mod:`classify.synthesis`: training clouds from a mesh per scan direction (Sung et al.:
  back-face culling, hidden-surface removal by ray casting, the front slope, noise, unit sphere).
- :mod:`classify.scan_synth`: synthesis mode ``scan`` (the shipped model's): a simulated pass over
  the mesh, reduced to what recon's highlight extension and front-slope correction make of it,
  from the geometry alone (beam fan ray casting, incidence threshold, detection lag).
- :mod:`classify.dataset`: :class:`~classify.dataset.CloudSet`, :func:`~classify.dataset.synthesize_set`
  over the object catalog with an on-disk cache, held-out settings, stratified splits.
- :mod:`classify.pointnet`: :class:`~classify.pointnet.PointNet` (width multiplier, BN folding).
- :mod:`classify.augment`, :mod:`classify.train`, :mod:`classify.checkpoint`, :mod:`classify.config`,
  :mod:`classify.workflow` (what ``auvlink train`` / ``auvlink eval`` run).
- :mod:`classify.infer`: ``Classifier.load(path).classify(points) -> (class_name, score)``.
- :mod:`classify.evaluate`: precision, recall, F1, confusion matrix and its PNG, look-alike pairs.
- :mod:`classify.baseline2d`, :mod:`classify.baseline_images`, :mod:`classify.baseline_eval`: the
  single-image 2D CNN baseline on simulated sonar images.

The classifier on clouds recon reconstructs from simulated passes is evaluation, in the application layer:
:mod:`auvlink.evaluation.recon_eval`.

Files touched: synthesized-cloud caches and checkpoints only; no ports.
"""
