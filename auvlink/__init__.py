"""auvlink: sensor drivers, wire formats and transports for an AUV with a forward-scan imaging sonar."""

from auvlink.version import __version__

__all__ = ["__version__"]
