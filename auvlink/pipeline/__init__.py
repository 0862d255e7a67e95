"""The mission pipeline: samples -> navigation -> reconstruction -> clusters -> classes -> outputs.

Part of the application layer (docs/ARCHITECTURE.md): it composes the packages below it (``auvlink``
drivers and codecs, ``logs_format``, ``recon``, ``classify``) and nothing below imports it back, so
the drivers never load the pipeline, Open3D or PyTorch. PyTorch itself loads only when a run
classifies (:meth:`auvlink.pipeline.engine.Engine.load_classifier`).
"""
