"""Outputs that never destroy what a user has: checked before any work, written under a temporary name.

Every command that writes follows the same rules (``auvlink sim/record/live/replay/demo/train/eval``,
``auvlink log import/export``):

* **Checked first.** :func:`check_output_file` / :func:`check_output_dir` run before any work: an
  existing file (or a non-empty folder) is refused unless ``force``; an output that *is* one of the
  inputs (same file, also through a symlink or another relative path) is refused even with
  ``force`` (also its ``.partial``; :class:`~auvlink.errors.InputOverwriteError`, exit 2; for the names
  a command writes inside its output folder see :mod:`auvlink.pipeline.run_guard`); a path under a regular file,
  or in a folder that cannot be written, is refused with the reason. Each refusal is one
  :class:`~auvlink.errors.OutputError` (one line, exit 1). An output folder's lock file
  (:data:`LOCK_NAME`, :func:`auvlink.pipeline.run_guard.output_dir_lock`) does not count as content.
* **Written under a temporary name, renamed when complete.** :func:`atomic_path` yields a hidden
  temporary name in the target's folder (same file system, so :func:`os.replace` is atomic) and
  renames it over the target only when the block ends normally; on an exception the temporary file
  is removed and the target is untouched. A mission log uses the visible name :func:`partial_path`
  (``LOG.mcap.partial``) instead, because a recording cut off by a crash must stay findable: it is
  readable up to its last complete chunk (see :class:`logs_format.writer.MissionLogWriter`).
* **Output folders** (:func:`atomic_dir`): the files are written into a hidden temporary folder;
  a new target is made by one rename of it, so a crash leaves no target or the whole new one. Into
  an existing folder (empty, or any with ``--force``) each top-level entry is moved in by its own
  rename (a subfolder such as ``objects/`` is swapped whole), so files of other names stay and no
  old file of a name the command writes survives beside the new ones; a crash in that last step
  (milliseconds) can leave some entries new and some old, never a half-written file.

``auvlink live`` fills its folder as the mission goes (detections as they are made), so there each
file is written atomically on its own instead (:func:`atomic_path`).
"""

from __future__ import annotations

import os
import secrets
import shutil
import stat
import tempfile
from collections.abc import Iterable, Iterator
from contextlib import contextmanager, suppress
from pathlib import Path

from auvlink.errors import InputOverwriteError, OutputError

PARTIAL_SUFFIX = ".partial"
LOCK_NAME = ".auvlink.lock"  # the lock file a run holds in its output folder (auvlink.pipeline.run_guard)

PathLike = str | os.PathLike[str]


def partial_path(path: PathLike) -> Path:
    """The visible name a mission log has while it is written: ``LOG.mcap.partial``."""
    p = Path(path)
    return p.with_name(p.name + PARTIAL_SUFFIX)


def same_file(a: PathLike, b: PathLike) -> bool:
    """Whether two paths name the same file (symlinks, ``..`` and relative paths resolved)."""
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist: compare where they would be
        return os.path.realpath(a) == os.path.realpath(b)


def _nearest_existing(path: Path) -> Path:
    p = path.absolute()
    while not os.path.lexists(p) and p != p.parent:
        p = p.parent
    return p


def check_writable_folder(folder: PathLike, what: str = "") -> None:
    """``folder`` (or, when it does not exist yet, its nearest existing ancestor) must be a folder in
    which this process can create files. Probed by creating and removing an unnamed file (root
    ignores permission bits, a read-only mount does not). ``what`` names the output in the message."""
    target = Path(folder)
    what = what or f"folder {target}"
    base = _nearest_existing(target)
    if not base.is_dir():
        raise OutputError(f"cannot create {what}: Not a directory ({base} is a file, not a folder)")
    try:
        with tempfile.TemporaryFile(dir=base):
            pass
    except OSError as exc:
        raise OutputError(f"cannot create {what}: {exc.strerror or exc} (in {base})") from exc


def check_output_file(path: PathLike, *, force: bool, inputs: Iterable[PathLike | None] = (),
                      option: str = "--out", what: str = "output") -> Path:
    """Refuse an output file that would destroy something (see the module docstring); returns it.
    ``what`` names the output in the messages ("log", "checkpoint", ...)."""
    p = Path(path)
    for src in inputs:
        if src is not None and (same_file(p, src) or same_file(partial_path(p), src)):
            raise InputOverwriteError(f"{option} {p} is the input {src} (or its {PARTIAL_SUFFIX}); write the "
                                      f"{what} to another file")
    if p.is_dir():
        raise OutputError(f"{option} {p} is a folder; give the {what}'s file name")
    if os.path.lexists(p):
        if p.exists() and not stat.S_ISREG(os.stat(p).st_mode):
            raise OutputError(f"{option} {p} exists and is not a regular file; give another file name")
        if not force:
            raise OutputError(f"{p} exists; give --force to replace it, or another {option}")
    tmp = partial_path(p)
    if os.path.lexists(tmp):
        raise OutputError(f"{tmp} exists: a run that was cut off (a log there replays up to its last "
                          "complete chunk: rename it to keep it) or one still writing; move it away first")
    check_writable_folder(p.absolute().parent, f"{what} {p}")
    return p


def check_output_dir(path: PathLike, *, force: bool, option: str = "--out") -> Path:
    """Refuse an output folder that would destroy something: a file in its place, a non-empty folder
    without ``force``, a path under a file, a folder that cannot be written. Returns it."""
    p = Path(path)
    if os.path.lexists(p) and not p.is_dir():
        raise OutputError(f"{option} {p} exists and is not a folder; give a new folder")
    if p.is_dir() and not force:
        entries = sorted(set(os.listdir(p)) - {LOCK_NAME})
        if entries:
            shown = ", ".join(entries[:4]) + (", ..." if len(entries) > 4 else "")
            raise OutputError(f"{p} is not empty ({shown}); give --force to write into it (files of the "
                              f"same names are replaced), or another {option}")
    check_writable_folder(p, f"output folder {p}")
    return p


def write_target(path: PathLike) -> Path:
    """Where a write to ``path`` lands: a symlink is followed (the link stays, its file is replaced)."""
    p = Path(path)
    return Path(os.path.realpath(p)) if p.is_symlink() else p


def _hidden_temp(target: Path) -> Path:
    suffix = target.suffix  # kept last: writers that pick the format from the suffix (savefig) still work
    stem = target.name[: -len(suffix)] if suffix else target.name
    return target.with_name(f".{stem}.{secrets.token_hex(4)}{PARTIAL_SUFFIX}{suffix}")


@contextmanager
def atomic_path(path: PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` to write; renamed over ``path`` when the block ends
    normally, removed when it raises (``path`` then keeps what it had)."""
    target = write_target(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = _hidden_temp(target)
    try:
        yield tmp
        os.replace(tmp, target)
    except BaseException:
        with suppress(OSError):
            os.unlink(tmp)
        raise


def write_text(path: PathLike, text: str) -> Path:
    """Write ``text`` to ``path`` atomically (see :func:`atomic_path`); returns ``path``."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return Path(path)


def _only_lock(folder: Path) -> bool:
    return os.listdir(folder) == [LOCK_NAME] and os.access(folder.absolute().parent, os.W_OK)


def _move_into(src_dir: Path, target: Path, trash: Path) -> None:
    for name in sorted(os.listdir(src_dir)):
        src, dst = src_dir / name, target / name
        if dst.is_dir() and not dst.is_symlink():
            os.rename(dst, trash / name)  # a subfolder is swapped whole: no stale file of the last run
        os.replace(src, dst)


@contextmanager
def atomic_dir(path: PathLike) -> Iterator[Path]:
    """Yield a temporary folder to fill; it becomes ``path`` when the block ends normally (see the
    module docstring), and is removed when it raises. For a new ``path`` the temporary folder is
    its hidden sibling (one rename); for an existing one it is a hidden folder inside it (the parent
    of ``--out ~`` need not be writable), and the entries move in one by one."""
    target = Path(path)
    exists = target.is_dir()
    base = target if exists else target.absolute().parent
    if exists and _only_lock(target):  # a new folder its run's lock made: filled from a sibling, as a new one
        base = target.absolute().parent
    base.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=base, prefix=f".{target.name}.", suffix=PARTIAL_SUFFIX))
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o777 & ~umask)  # mkdtemp makes 0700; an output folder gets the usual mode
    try:
        yield tmp
        if not exists and not os.path.lexists(target):
            os.rename(tmp, target)
            return
        trash = Path(tempfile.mkdtemp(dir=base, prefix=f".{target.name}.", suffix=".old"))
        try:
            _move_into(tmp, target, trash)
        finally:
            shutil.rmtree(trash, ignore_errors=True)
        tmp.rmdir()
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
