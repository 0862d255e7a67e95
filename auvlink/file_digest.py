"""A file's SHA-256, read in blocks: what batch records, their outputs and inference exports are checked by."""

from __future__ import annotations

import hashlib
import os

HASH_BLOCK = 1 << 20  # bytes read at a time (memory stays at one block however large the file)


def sha256_file(path: str | os.PathLike[str]) -> str:
    """Hex SHA-256 of a file, read in :data:`HASH_BLOCK` blocks (never the whole file in memory)."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while block := f.read(HASH_BLOCK):
            h.update(block)
    return h.hexdigest()
