"""Incremental framers: cut a byte stream into whole wire frames, resynchronise, count losses."""

from auvlink.framing.base import Framer, FramerStats

__all__ = ["Framer", "FramerStats"]
