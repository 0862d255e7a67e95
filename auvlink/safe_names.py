"""File names made from data (class names, device names, log names): safe, unique, inside their folder.

:func:`safe_name` turns any string into one file-name component: only ASCII letters, digits, ``_``, ``-``
and single inner dots (every other run of characters, path separators and control characters included,
becomes one ``_``); no leading or trailing dot or ``_`` (so never ``.``, ``..`` or a hidden file); at most
:data:`MAX_NAME` characters (a longer name is cut and ends in 8 hex digits of its SHA-256, so distinct long
names stay distinct); never empty (``fallback``) and never a name Windows reserves (``CON``, ``NUL``,
``COM1``, ...: prefixed with ``_``). A name that is already safe is returned unchanged.

:class:`UniqueNames` hands out such names, one per key, unique among themselves (compared without case, as
macOS and Windows file systems do) and apart from names reserved by the caller: a clash gets ``-2``,
``-3``, ... :func:`path_inside` joins a relative name to a folder and refuses a result outside it.
"""

from __future__ import annotations

import hashlib
import os
import re
from collections.abc import Iterable
from pathlib import Path

from auvlink.errors import OutputError

#: longest component made (characters = bytes: ASCII only); ext4 and NTFS allow 255, room is left for a
#: prefix such as ``object_001_``, a suffix such as ``-12.csv`` and the atomic writer's temporary name
MAX_NAME = 120
#: device names Windows reserves whatever the extension (Microsoft, "Naming Files, Paths, and Namespaces")
WINDOWS_RESERVED = frozenset({"con", "prn", "aux", "nul", *(f"com{i}" for i in range(10)),
                              *(f"lpt{i}" for i in range(10))})
_UNSAFE = re.compile(r"[^A-Za-z0-9_.-]+")
_DOTS = re.compile(r"\.{2,}")
_HASH_HEX = 8  # hex digits of SHA-256 that keep two cut names apart


def safe_name(text: str, fallback: str = "unnamed") -> str:
    """``text`` as one safe file-name component (see the module docstring); ``fallback`` (itself made
    safe, ``unnamed`` if that leaves nothing) when nothing of ``text`` is left."""
    name = _DOTS.sub(".", _UNSAFE.sub("_", str(text))).strip("._")
    if len(name) > MAX_NAME:
        digest = hashlib.sha256(str(text).encode("utf-8", "surrogatepass")).hexdigest()[:_HASH_HEX]
        name = f"{name[:MAX_NAME - _HASH_HEX - 1].rstrip('._')}-{digest}"
    if not name:
        return safe_name(fallback) if fallback and fallback != text else "unnamed"
    if name.split(".", 1)[0].lower() in WINDOWS_RESERVED:
        name = f"_{name}"
    return name


class UniqueNames:
    """Safe names, one per key, unique among those handed out and the ``reserved`` ones (without case).

    ``name_for(key, suffix)`` returns the stem for ``key``: ``stem + suffix`` is the entry written (``suffix``
    such as ``.csv``; the clash is judged on the whole entry); the same key and suffix give the same stem.
    """

    def __init__(self, reserved: Iterable[str] = (), fallback: str = "unnamed") -> None:
        self._taken = {r.lower() for r in reserved}
        self._given: dict[tuple[str, str], str] = {}
        self.fallback = fallback

    def name_for(self, key: str, suffix: str = "", fresh: bool = False) -> str:
        """The stem for ``key`` (``fresh``: a new one even if ``key`` had one)."""
        if not fresh and (key, suffix) in self._given:
            return self._given[(key, suffix)]
        base = safe_name(key, self.fallback)
        stem, k = base, 2
        while f"{stem}{suffix}".lower() in self._taken:
            stem, k = safe_name(f"{base}-{k}"), k + 1  # made safe again: "_LPT1" + "-2" is "LPT1-2"
        self._taken.add(f"{stem}{suffix}".lower())
        self._given[(key, suffix)] = stem
        return stem


def unique_names(keys: Iterable[str], reserved: Iterable[str] = (), fallback: str = "unnamed") -> list[str]:
    """:func:`safe_name` of every key, made unique in order (an equal key again gets a name of its own)."""
    names = UniqueNames(reserved, fallback)
    return [names.name_for(key, "", fresh=True) for key in keys]


def path_inside(folder: Path, name: str | os.PathLike[str]) -> Path:
    """``folder / name``, or :class:`~auvlink.errors.OutputError` when it would resolve (links followed)
    outside ``folder``."""
    root = os.path.realpath(folder)
    target = os.path.realpath(os.path.join(root, name))
    if os.path.commonpath([root, target]) != root or target == root:
        raise OutputError(f"file name {os.fspath(name)!r} would be written outside {folder}; not written")
    return Path(folder) / name
