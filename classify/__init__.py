"""classify: name the objects recon finds, with PointNet trained on clouds synthesized from meshes.

This package is the runtime a vehicle needs (PyTorch and NumPy only; it imports neither the simulator, Open3D nor
:mod:`classify.training`, a contract of ``.importlinter``). Import what you use; torch loads only with the model
modules:

- :mod:`classify.infer`: :class:`~classify.infer.Classifier` (``Classifier.load(path)``; ``probabilities`` of
  clouds as 4 yaw views averaged, ``decide`` the class or ``clutter``; ``classify`` one cloud).
- :mod:`classify.pointnet`: :class:`~classify.pointnet.PointNet` (width multiplier, BN folding);
  :mod:`classify.ensemble`: several seeds' models read as one.
- :mod:`classify.checkpoint`: one file of weights and plain metadata (calibration, members), checked by
  :mod:`classify.checkpoint_meta`.
- :mod:`classify.normalize`: a cloud in metres -> the network's input (unit sphere, or height above the seabed).
- :mod:`classify.labels`: ``clutter`` beside the object catalogue's classes; :mod:`classify.errors`.
- ``classify/data/``: the shipped model (``pointnet_default.pt``) and the settings it was trained with.

Synthesis of training clouds, training, evaluation and the 2D baseline (which import the simulator and Open3D) are
in :mod:`classify.training`.

Files touched: checkpoints only; no ports.
"""
