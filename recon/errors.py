"""Errors of the reconstruction package, rooted in :class:`auvlink.errors.AuvlinkError`."""

from __future__ import annotations

from auvlink.errors import AuvlinkError


class ReconError(AuvlinkError):
    """Root of the errors raised by :mod:`recon`."""


class GeometryError(ReconError):
    """A pose or a sonar geometry the reconstruction cannot serve (e.g. pitch near +-90 deg)."""


class NavigationError(ReconError):
    """Navigation inputs that cannot make a trajectory, or a time outside the trajectory."""
