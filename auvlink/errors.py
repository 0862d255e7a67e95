"""One error tree for auvlink, split by phase (after python-can's ``CanError``).

Every error raised by the package derives from :class:`AuvlinkError`, and every error that
wraps a lower-level exception is raised with ``raise ... from exc`` so the cause is kept.
Errors that compare something carry what was *expected* and what *came*.
"""

from __future__ import annotations


class AuvlinkError(Exception):
    """Root of every error raised by auvlink."""


# --- transports ---------------------------------------------------------------------------
class TransportError(AuvlinkError):
    """A transport (serial, TCP, CAN) failed."""


class TransportInitError(TransportError):
    """Opening a transport failed: bad URL, missing device, permission, unknown interface."""


class TransportOperationError(TransportError):
    """Reading from or writing to an open transport failed (device gone, socket reset)."""


class TransportTimeoutError(TransportError):
    """A transport operation did not complete in time."""


# --- framing and decoding ----------------------------------------------------------------
class DecodeError(AuvlinkError):
    """A frame's bytes do not decode into a record."""

    def __init__(self, message: str, *, fmt: str = "", offset: int | None = None) -> None:
        super().__init__(message)
        self.fmt = fmt
        self.offset = offset


class ChecksumError(DecodeError):
    """A frame's checksum or CRC does not match; carries the expected and the actual value."""

    def __init__(self, fmt: str, expected: int, actual: int) -> None:
        super().__init__(
            f"{fmt}: checksum mismatch: expected 0x{expected:X}, computed 0x{actual:X}", fmt=fmt
        )
        self.expected = expected
        self.actual = actual


class EncodeError(AuvlinkError):
    """A record cannot be encoded into its wire format (value out of range, wrong shape)."""


class UnknownFormatError(AuvlinkError, KeyError):
    """A wire-format name is not in the registry."""

    def __str__(self) -> str:  # KeyError quotes its message otherwise
        return str(self.args[0]) if self.args else "unknown format"


# --- configuration -----------------------------------------------------------------------
class ConfigError(AuvlinkError):
    """A configuration or scene file is wrong; the message names the key and the fix."""

    def __init__(self, key: str, problem: str, fix: str = "") -> None:
        msg = f"config key {key!r}: {problem}"
        if fix:
            msg += f" ({fix})"
        super().__init__(msg)
        self.key = key
        self.problem = problem
        self.fix = fix


# --- outputs -----------------------------------------------------------------------------
class OutputError(AuvlinkError):
    """An output path cannot be used: it exists (without ``--force``), is an input, or cannot be written."""


class InputOverwriteError(OutputError):
    """An output is, or would replace, one of the command's inputs: refused even with ``--force`` (exit 2)."""

    exit_status = 2
