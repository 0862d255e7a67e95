"""Errors of the classify package (all derive from :class:`auvlink.errors.AuvlinkError`)."""

from __future__ import annotations

from auvlink.errors import AuvlinkError


class ClassifyError(AuvlinkError):
    """Root of the classify package's errors."""


class InvalidCloudError(ClassifyError, ValueError):
    """A point cloud cannot be classified: wrong shape, empty, or holding NaN or inf."""


class SynthesisError(ClassifyError):
    """A training cloud cannot be synthesized from a mesh (bad mesh, nothing visible)."""


class CheckpointError(ClassifyError):
    """A model checkpoint is missing, unreadable or of another format."""


class InferenceExportWarning(UserWarning):
    """A checkpoint is classified with PyTorch because its inference export is missing, stale or unreadable."""
