"""Progress bars only where a person watches them: on a terminal.

tqdm redraws its bar with carriage returns; written to a file or a pipe (a log of ``auvlink sim 2>
sim.log``, a CI job) that becomes thousands of partial lines. Every progress bar of the project is
made here, by :func:`progress_bar`, and shows only when it was asked for *and* its stream (stderr by
default) is a terminal.
"""

from __future__ import annotations

import sys
from collections.abc import Iterable
from typing import IO, Any, TypeVar

from tqdm import tqdm

T = TypeVar("T")


def on_terminal(stream: IO[str] | None = None) -> bool:
    """Whether ``stream`` (default: the current ``sys.stderr``) is a terminal."""
    stream = sys.stderr if stream is None else stream
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # no isatty, or a closed stream
        return False


def progress_bar(iterable: Iterable[T] | None = None, *, enabled: bool = True, **kwargs: Any) -> tqdm[T]:
    """A tqdm bar over ``iterable`` (or a manual one with ``total=``), disabled unless ``enabled`` and
    its ``file`` (default stderr) is a terminal. Other keyword arguments go to tqdm."""
    stream = kwargs.get("file")
    return tqdm(iterable, disable=not (enabled and on_terminal(stream)), **kwargs)
