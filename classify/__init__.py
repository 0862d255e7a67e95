"""classify: name the objects recon finds, with PointNet trained on clouds synthesized from meshes.

This package is the runtime a vehicle needs (NumPy, and PyTorch for checkpoints; it imports neither the simulator,
Open3D nor :mod:`classify.training`, a contract of ``.importlinter``). Import what you use; torch loads only with the
model modules:

- :mod:`classify.numpy_infer`: :func:`~classify.numpy_infer.load_classifier` (what runs call): the checkpoint's
  inference export run with NumPy (no PyTorch) when it matches the checkpoint, else the PyTorch classifier;
  :mod:`classify.inference_export`: that export (``X.npz`` beside ``X.pt``, the folded weights and the settings
  inference reads, tied to the checkpoint by its SHA-256).
- :mod:`classify.cloud_classifier`: :class:`~classify.cloud_classifier.CloudClassifier`, what both classifiers do
  around the network (``probabilities`` of clouds as 4 yaw views averaged, ``decide`` the class or ``clutter``;
  ``classify`` one cloud).
- :mod:`classify.infer`: :class:`~classify.infer.Classifier` (``Classifier.load(path)``), the network with
  PyTorch.
- :mod:`classify.pointnet`: :class:`~classify.pointnet.PointNet` (width multiplier, BN folding);
  :mod:`classify.ensemble`: several seeds' models read as one.
- :mod:`classify.checkpoint`: one file of weights and plain metadata (calibration, members), checked by
  :mod:`classify.checkpoint_meta`.
- :mod:`classify.normalize`: a cloud in metres -> the network's input (unit sphere, or height above the seabed).
- :mod:`classify.labels`: ``clutter`` beside the object catalogue's classes; :mod:`classify.errors`.
- ``classify/data/``: the shipped model (``pointnet_default.pt``), its inference export (``pointnet_default.npz``)
  and the settings it was trained with.

Synthesis of training clouds, training, evaluation and the 2D baseline (which import the simulator and Open3D) are
in :mod:`classify.training`.

Files touched: checkpoints only; no ports.
"""
