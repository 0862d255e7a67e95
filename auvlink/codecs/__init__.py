"""Sensor codecs: pure ``decode(bytes) -> record`` / ``encode(record) -> bytes`` pairs in SI units."""
