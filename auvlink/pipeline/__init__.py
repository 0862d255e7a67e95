"""The mission pipeline: samples -> navigation -> reconstruction -> clusters -> classes -> outputs.

This is the one place that composes the packages (``auvlink`` drivers and codecs, ``logs_format``,
``recon``, ``classify``); ``recon`` and ``classify`` are imported only when a pipeline runs, so the
drivers never load Open3D or PyTorch.
"""
