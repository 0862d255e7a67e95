"""Transports move bytes; they never decode. A URL names each one (see :func:`open_transport`)."""

from auvlink.transports.base import Transport, open_transport, register_scheme

__all__ = ["Transport", "open_transport", "register_scheme"]
