"""Atomic file writes: a failed or interrupted write never leaves a half-written file.

The one place jellysim writes files atomically (trajectories, ParaView frames, USD, glTF,
videos, body files): the data goes to a temporary file in the target's folder, which then
replaces the target with :func:`os.replace`.  File mode: an existing target's mode is kept;
a new file gets ``0o666 & ~umask`` (rw-r--r-- under the usual umask), like ``open(path, "w")``.
"""
from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

from ..errors import OutputError

__all__ = ["atomic_path", "atomic_write", "describe_os_error", "guard_file", "guard_folder"]


def describe_os_error(exc: OSError) -> str:
    """One line for an operating-system error met writing or reading ``exc.filename``: the
    path the user gave (not a hidden staging folder ``.new-*``), what is wrong
    with it, and what would fix it (the artist trial: "afile/r: Not a directory",
    "/proc/r: No such file or directory", "rofs/.new-ec9frqa1: Read-only file system")."""
    import errno

    name = getattr(exc, "filename", None)
    why = exc.strerror or str(exc)
    if not name:
        return why
    path = Path(name)
    if path.name.startswith(".new-"):  # (a staging folder of ours: name its folder)
        path = path.parent
    if exc.errno == errno.ENOTDIR:
        for up in [path, *path.parents]:
            if up.exists() and not up.is_dir():
                return f"{path}: {up} is a file, not a folder (choose another path)"
    if exc.errno == errno.EEXIST and path.is_file():  # (a folder was to be made there)
        return (f"{path}: a file of that name is where a folder is needed (an output name "
                "without a suffix is a folder of frames): give a suffix (.mp4, .png) or "
                "another name")
    if exc.errno == errno.EROFS:
        return f"{path}: {why} (write somewhere else: a folder you can write to)"
    if exc.errno in (errno.EACCES, errno.EPERM):
        return f"{path}: {why} (check the permissions of {path} and of its folder)"
    return f"{path}: {why}"


_ORPHAN = None
_SWEPT: set = set()
"""Folders this process has swept already (once each: an export of thousands of frames into
one folder would otherwise list it once per frame)."""


def _drop_orphans(folder: Path) -> None:
    """Delete the temporary files (``.<name>.<pid>-<8 random>...``) and staging folders
    (``.new-<pid>-<8 random>``) that a process killed while writing left in ``folder``
    (SIGKILL runs no cleanup: a killed render's ``.demo.mp4.kevucuw0.mp4`` stayed for good,
    the reliability trial): those whose process is gone, whatever file they were for.  One
    of a live process, or a name not of this form, is left."""
    import re
    import shutil

    from .lock import _alive

    global _ORPHAN
    key = os.path.abspath(folder)
    if key in _SWEPT:
        return
    _SWEPT.add(key)
    if _ORPHAN is None:
        _ORPHAN = re.compile(r"^\.(?:new-|.+\.)(\d+)-[a-z0-9_]{8}(?:\.[A-Za-z0-9]+)?$")
    try:
        names = [p for p in folder.iterdir() if p.name.startswith(".")]
    except OSError:
        return
    for p in names:
        hit = _ORPHAN.match(p.name)
        if hit and int(hit.group(1)) != os.getpid() and not _alive(int(hit.group(1))):
            try:
                shutil.rmtree(p) if p.is_dir() else p.unlink()
            except OSError:
                pass


def _final_mode(path: Path) -> int:
    try:
        return path.stat().st_mode & 0o7777
    except FileNotFoundError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


@contextmanager
def atomic_path(path, suffix: str | None = None, *, fsync: bool = False):
    """Yield a temporary path next to ``path`` (same suffix, so writers that pick the format
    by name work); on success it replaces ``path`` at once, on an exception it is deleted.
    ``fsync``: flush the data to disk before the replace (durable across a power cut)."""
    path = Path(path)
    if path.is_dir():
        raise OutputError(f"cannot write {path}: it is a folder; give a file name")
    for up in path.parents:
        if up.exists():
            if not up.is_dir():
                raise OutputError(f"cannot write {path}: {up} is a file, not a folder")
            break
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        _drop_orphans(path.parent)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.{os.getpid()}-",
                                   suffix=suffix or path.suffix, dir=path.parent)
    except OSError as exc:
        raise OutputError(f"cannot write {path}: {exc.strerror or exc} (its folder "
                          f"{path.parent} must be a folder you can write to)") from None
    os.close(fd)
    os.chmod(tmp, _final_mode(path))   # mkstemp makes 0600
    try:
        yield Path(tmp)
        if fsync and os.path.exists(tmp):
            fd = os.open(tmp, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def atomic_write(path, write, *, fsync: bool = True) -> Path:
    """Call ``write(fh)`` with a binary file handle, atomically replacing ``path``."""
    path = Path(path)
    with atomic_path(path, fsync=fsync) as tmp:
        with open(tmp, "wb") as fh:
            write(fh)
    return path


def guard_file(path, overwrite: bool, flag: str = "--overwrite") -> None:
    """Refuse to replace an existing file ``path`` unless ``overwrite`` (nothing already
    written is lost by accident)."""
    path = Path(path)
    if path.exists() and not overwrite:
        raise OutputError(f"{path} exists; pass {flag} to replace it (or choose another name)")


def guard_folder(folder, patterns, overwrite: bool, flag: str = "--overwrite") -> None:
    """Before writing numbered files into ``folder``: refuse when it already holds files
    matching ``patterns`` (globs; new frames would mix with stale ones) unless ``overwrite``
    (then :func:`staged_output` replaces them, once the new frames are all written)."""
    folder = Path(folder)
    if not folder.is_dir():
        return
    stale = sorted({p for pat in patterns for p in folder.glob(pat) if p.is_file()})
    if stale and not overwrite:
        raise OutputError(f"{folder} already holds {len(stale)} file(s) like {stale[0].name} "
                          f"from an earlier output: the new frames would mix with them; "
                          f"choose another folder, or pass {flag} to replace them")


@contextmanager
def staged_output(folder, patterns):
    """Write an output of many files (numbered frames, a ``.pvd`` and its frame folder) into
    a hidden staging folder inside ``folder``, yielded, and move it into ``folder`` only once
    all is written: then, in each folder that receives new files matching ``patterns``
    (globs), the old files matching them go first (no stale frame survives a shorter run).
    If the writing fails or is interrupted (Ctrl-C), the staging folder is deleted and the
    earlier output is untouched (a render with ``--overwrite`` stopped half-way used to leave
    7 of 61 frames)."""
    import shutil

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    _drop_orphans(folder)
    stage = Path(tempfile.mkdtemp(prefix=f".new-{os.getpid()}-", dir=folder))
    try:
        yield stage
        _merge(stage, folder, patterns)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def _merge(src: Path, dst: Path, patterns) -> None:
    import fnmatch

    dst.mkdir(exist_ok=True)
    entries = sorted(src.iterdir())
    def framed(name):
        return any(fnmatch.fnmatchcase(name, pat) for pat in patterns)
    if any(p.is_file() and framed(p.name) for p in entries):
        for old in dst.iterdir():
            if old.is_file() and framed(old.name):
                old.unlink()
    for p in entries:
        if p.is_dir():
            _merge(p, dst / p.name, patterns)
        else:
            os.replace(p, dst / p.name)
