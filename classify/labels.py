"""The classifier's labels beyond the object catalogue: ``clutter`` (not an object: what recon makes of a rough
seabed, :mod:`classify.training.clutter_synth`). A scene cannot place clutter; only the classifier names it."""

from __future__ import annotations

from collections.abc import Sequence

CLUTTER = "clutter"


def with_clutter(class_names: Sequence[str], clutter: bool) -> tuple[str, ...]:
    """The classifier's outputs: the object classes, then ``clutter`` when it is trained."""
    names = tuple(n for n in class_names if n != CLUTTER)
    return (*names, CLUTTER) if clutter else names
