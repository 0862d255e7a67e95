"""auvlink: sensor drivers, wire formats and transports for an AUV with a forward-scan imaging sonar."""

__version__ = "0.1.0"
