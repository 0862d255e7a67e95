"""A run never destroys its own inputs, and holds its output folder alone.

* **Inputs are never outputs.** :func:`refuse_input_overwrite` runs before any work: an output file
  (or its ``.partial``), or a name a command writes in its output folder (a file such as
  ``summary.json``, or anything under a folder it replaces whole such as ``objects/``), that is one of
  the inputs (the log and its ``.partial``, a ``--config``, ``--model`` or ``--scene``) is refused, with
  or without ``--force``: one :class:`~auvlink.errors.InputOverwriteError` line naming both paths,
  exit status 2. Paths are compared resolved (symlinks, ``..``) and, where both exist, by device and
  inode (:func:`os.path.samefile`: hard links too).
* **One run per output folder.** :func:`output_dir_lock` holds ``DIR/.auvlink.lock`` with
  :func:`fcntl.flock` for the run: a second run into the same folder is refused (one line naming the
  holder's pid) while the first holds it. The kernel drops the lock when its process ends however it
  ends (kill -9 included), so a lock file left by a dead process is simply taken over. The file is
  removed at the end, also on an error; a folder the lock made and the run left empty is removed too.
"""

from __future__ import annotations

import errno
import fcntl
import os
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager, suppress
from pathlib import Path

from auvlink.atomic import LOCK_NAME, check_output_dir, partial_path
from auvlink.errors import InputOverwriteError, OutputError

PathLike = str | os.PathLike[str]

#: top-level entries ``auvlink replay`` writes in its folder (auvlink.pipeline.outputs, gis, report);
#: ``live`` and ``demo`` add their mission log. A test checks a real replay writes no other name.
REPLAY_OUTPUTS = frozenset({"detections.jsonl", "cloud.ply", "objects", "results.mcap", "summary.json",
                            "track.csv", "detections.geojson", "track.geojson", "detections.kml",
                            "report.html"})
#: top-level files ``auvlink batch`` writes in its folder (auvlink.pipeline.batch); each mission is a sub-folder
BATCH_FILES = frozenset({"batch.json", "catalogue.geojson", "catalogue.csv"})
LOCK_TAKE_TRIES = 5  # a holder that removes the file as we open it: open it again, at most this often


def _real(path: PathLike) -> str:
    return os.path.realpath(os.path.abspath(path))


def _same(a: PathLike, b: PathLike) -> bool:
    """Whether ``a`` and ``b`` are one file: by device and inode where both exist, else resolved paths."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return _real(a) == _real(b)


def _inputs(inputs: Iterable[PathLike | None]) -> list[Path]:
    """The inputs given, each with its ``.partial`` (a log still written, or cut off)."""
    out: list[Path] = []
    for src in inputs:
        if src is not None:
            out += [Path(src), partial_path(src)]
    return out


def _under(path: PathLike, folder: PathLike) -> Path | None:
    """``path`` relative to ``folder`` when it lies inside it (resolved), else None."""
    p, f = Path(_real(path)), Path(_real(folder))
    return p.relative_to(f) if p != f and p.is_relative_to(f) else None


def refuse_input_overwrite(inputs: Iterable[PathLike | None], *, files: Iterable[tuple[str, PathLike | None]] = (),
                           folder: tuple[str, PathLike] | None = None,
                           writes: Callable[[Path], bool] | None = None) -> None:
    """Raise :class:`InputOverwriteError` when an output is, or would replace, an input (module docstring).

    ``files``: (option, path) of output files (their ``.partial`` too). ``folder``: (option, DIR) of an
    output folder; ``writes(rel)`` says whether the command writes (or replaces whole) the entry
    ``DIR/rel`` (default: the first part of ``rel`` is in :data:`REPLAY_OUTPUTS`). A hard link or a
    symlink of an input at a written name is found too."""
    srcs = _inputs(inputs)
    for option, out in files:
        if out is None:
            continue
        for target in (Path(out), partial_path(out)):
            for src in srcs:
                if _same(target, src):
                    raise InputOverwriteError(f"{option} {out} would replace the input {src}; "
                                              f"write to another {option}")
    if folder is None:
        return
    option, out_dir = folder
    writes = writes or (lambda rel: rel.parts[0] in REPLAY_OUTPUTS)
    names = [name for name in _listdir(out_dir) if writes(Path(name))]
    for src in srcs:
        rel = _under(src, out_dir)
        hit = rel if rel is not None and writes(rel) else None
        hit = hit or next((Path(n) for n in names if _same(Path(out_dir) / n, src)), None)
        if hit is not None:
            raise InputOverwriteError(f"{option} {out_dir} would replace the input {src} (with its own "
                                      f"{hit}); give another {option}, or move the input out of it")


def _listdir(folder: PathLike) -> list[str]:
    try:
        return sorted(os.listdir(folder))
    except OSError:
        return []


def _holder(path: Path) -> str:
    try:
        pid = path.read_text().split()[0]
    except (OSError, IndexError):
        return "another auvlink run"
    return f"another auvlink run (pid {pid})"


def _make_dirs(folder: Path) -> list[Path]:
    """Create ``folder`` and its missing parents; returns those created, deepest first."""
    missing: list[Path] = []
    p = folder.absolute()
    while not os.path.lexists(p) and p != p.parent:
        missing.append(p)
        p = p.parent
    folder.mkdir(parents=True, exist_ok=True)
    return missing


def _take(path: Path, option: str, folder: Path) -> int:
    """Open and flock ``path``; returns the descriptor (the lock file's current inode, locked)."""
    for _ in range(LOCK_TAKE_TRIES):
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            os.close(fd)
            if exc.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise OutputError(f"cannot lock {option} {folder}: {exc.strerror or exc}") from exc
            raise OutputError(f"{option} {folder} is in use by {_holder(path)}; wait for it to end, "
                              f"or give another {option}") from None
        try:
            same = os.fstat(fd).st_ino == os.stat(path).st_ino  # not removed by a holder that just ended
        except FileNotFoundError:
            same = False
        if same:
            return fd
        os.close(fd)
    raise OutputError(f"{option} {folder}: its lock file keeps changing; is another auvlink run starting there?")


@contextmanager
def output_dir_lock(folder: PathLike, *, force: bool, option: str = "--out") -> Iterator[Path]:
    """Check ``folder`` (:func:`~auvlink.atomic.check_output_dir`), create it, hold its lock for the block
    (see the module docstring) and check it again under the lock (a run that ended meanwhile may
    have filled it). Yields the folder."""
    target = Path(folder)
    check_output_dir(target, force=force, option=option)
    created = _make_dirs(target)
    lock = target / LOCK_NAME
    try:
        fd = _take(lock, option, target)
    except BaseException:
        _remove_empty(created)
        raise
    try:
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        check_output_dir(target, force=force, option=option)
        yield target
    finally:
        with suppress(OSError):
            os.unlink(lock)  # while held: a run that opened it meanwhile finds it gone and opens it again
        os.close(fd)
        _remove_empty(created)


def _remove_empty(created: list[Path]) -> None:
    for p in created:
        with suppress(OSError):
            p.rmdir()  # only when empty: what the run wrote stays
