"""One run per output folder: a lock file claimed before anything there is touched.

A second ``jellysim run`` (or ``--resume``) into a folder that a live run is writing would
delete its partial files and interleave frames; :func:`claim` refuses it, naming the process.
A lock left by a run that was killed (its process is gone) is taken over.
"""
from __future__ import annotations

import os
import socket
from pathlib import Path

from ..errors import OutputError

__all__ = ["LOCK_NAME", "claim", "refuse_if_held", "writer_of"]

LOCK_NAME = ".jellysim.lock"
"""The lock file in the output folder: ``"<pid> <host>"`` of the run writing there."""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's live process
        return True
    except OSError:
        return False
    return True


def _holder(out_dir: Path, path: Path, host: str):
    """``(error, stale)``: the :class:`OutputError` of a live run holding ``path`` (else
    ``None``), and whether the lock is a killed run's (its process gone)."""
    try:
        pid_text, _, owner = path.read_text().strip().partition(" ")
        pid = int(pid_text)
    except (OSError, ValueError):
        return None, False  # gone, unreadable or being written: look again
    if owner != host:
        return OutputError(
            f"{out_dir}: a jellysim run on {owner} (process {pid}) is writing here; "
            f"choose another --out, or delete {path} if no run is active"), False
    if _alive(pid):
        return OutputError(
            f"{out_dir}: another jellysim run (process {pid}) is writing here; wait "
            "for it or stop it (Ctrl-C: it can be resumed with --resume), or choose "
            "another --out"), False
    return None, True


def writer_of(out_dir) -> str | None:
    """``"process N"`` (or ``"process N on HOST"``) of a live run writing ``out_dir``, else
    ``None`` (no lock, or a killed run's)."""
    path = Path(out_dir) / LOCK_NAME
    if not path.exists():
        return None
    host = socket.gethostname()
    error, _ = _holder(Path(out_dir), path, host)
    if error is None:
        return None
    try:  # (the run may end, and take its lock, between the two reads)
        pid, _, owner = path.read_text().strip().partition(" ")
    except OSError:
        return None
    return f"process {pid}" + ("" if owner == host else f" on {owner}")


def refuse_if_held(out_dir: Path) -> None:
    """Raise the :class:`OutputError` of :func:`claim` if a live run holds ``out_dir``,
    touching nothing (a check before anything there is deleted)."""
    path = Path(out_dir) / LOCK_NAME
    if path.exists():
        error, _ = _holder(Path(out_dir), path, socket.gethostname())
        if error is not None:
            raise error


def claim(out_dir: Path) -> Path:
    """Create ``out_dir / LOCK_NAME`` for this process and return its path (the caller
    deletes it when done), or raise :class:`OutputError` if a live run holds the folder."""
    path = Path(out_dir) / LOCK_NAME
    host = socket.gethostname()
    for _ in range(3):
        try:
            fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            error, stale = _holder(Path(out_dir), path, host)
            if error is not None:
                raise error from None
            if stale:
                path.unlink(missing_ok=True)  # its process is gone: a killed run's lock
            continue
        with os.fdopen(fd, "w") as f:
            f.write(f"{os.getpid()} {host}\n")
        return path
    raise OutputError(f"{out_dir}: cannot claim {path} (another process keeps creating it)")
