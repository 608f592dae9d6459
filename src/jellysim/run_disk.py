"""A run's disk space: checked before it starts, and what a full disk says (how to go on)."""
from __future__ import annotations

import shlex
from pathlib import Path

from .errors import OutputError, ResourceError
from .io.checkpoint import CHECKPOINT, FINAL_CHECKPOINT

__all__ = ["LARGE_TRAJECTORY_BYTES"]

LARGE_TRAJECTORY_BYTES = 1 << 30
"""A run whose trajectory will exceed this says so before it starts."""


def _check_disk(out_dir: Path, total: int, every: int, n: int, messages: list, *,
                freed: int = 0, frame_bytes: int = 0, have: int = 0) -> None:
    """Refuse a run whose trajectory cannot fit the free disk space (plus ``freed`` bytes, the
    earlier run's files it replaces); note a large one.  ``frame_bytes``: an upper bound of
    one ParaView frame (uncompressed; they compress to about a third): warned, not refused.
    ``have``: frames a resumed run's stream holds already (on disk: not counted again; a
    resume after a full disk was refused for the room its own frames took)."""
    import shutil

    frames = total // every + 1 + (1 if total % every else 0)  # the start, each every, the end
    # positions + velocities in the stream (those not there yet), then the final .npz copy
    need = (max(0, frames - have) + frames) * n * 48
    free = shutil.disk_usage(out_dir).free + freed
    gib = need / (1 << 30)
    if need > free:
        raise ResourceError(f"{out_dir}: the trajectory ({frames:,} frames of {n:,} points) "
                            f"needs about {gib:.3g} GiB on disk, {free / (1 << 30):.3g} GiB "
                            "free; save fewer frames ([output] every) or free space")
    if need + frames * frame_bytes > free:
        messages.append(f"the ParaView frames may need up to "
                        f"{frames * frame_bytes / (1 << 30):.3g} GiB ({frames:,} frames), with "
                        f"{(free - need) / (1 << 30):.3g} GiB free beside the trajectory: "
                        "--no-vtu or fewer frames ([output] every) if the disk fills")
    elif frames * frame_bytes > LARGE_TRAJECTORY_BYTES:  # (scale trial: 1.1 GB unsaid for a
        messages.append(  # 10,948-point body's 181 frames, 9-10 GB at 100k points)
            f"the ParaView frames (.vtu, for ParaView only) will take up to "
            f"{frames * frame_bytes / (1 << 30):.3g} GiB ({frames:,} frames of up to "
            f"{frame_bytes / (1 << 20):.3g} MiB); --no-vtu writes none (the trajectory alone "
            "is rendered and exported), or save fewer frames ([output] every)")
    if 2 * frames * n * 48 > LARGE_TRAJECTORY_BYTES:
        messages.append(f"the trajectory will take about {frames * n * 48 / (1 << 30):.3g} GiB "
                        f"({frames:,} frames "
                        f"of {n:,} points; [output] every = {every} steps)")


def _vtu_frame_bound(model, skin) -> int:
    """Bytes of one uncompressed ParaView frame (body and skin), an upper bound: points
    (position, velocity, rest: 72 bytes; a run's handles, pinned, point force and gravity
    scale: 40 more) and cells (connectivity, offset, type and data: a
    physical run's tets carry their volume ratio, von Mises stress and 9 stress components,
    129 bytes a tet; 49 before session 28 left those out, 3.8 MB where a 10,948-point body's
    frames took 5.8 MB: scale trial)."""
    fem = getattr(model, "fem", None)
    cells = 129 * fem.tet_count if fem is not None else 25 * model.spring_count
    if skin is not None:
        cells += 24 * len(skin.rest_vertices) + 33 * len(skin.faces)
    return 112 * model.point_count + cells + 4096


def _disk_full(exc: OSError, out_dir: Path, scene, where: str = "") -> OutputError | None:
    """The error of a full disk (or quota): the file, and how to go on; ``None`` for another
    ``OSError`` (raised as it is)."""
    import errno

    if exc.errno not in (errno.ENOSPC, errno.EDQUOT):
        return None
    again = (f"continue from the last checkpoint with: jellysim run "
             f"{shlex.quote(str(scene.name))} --resume {shlex.quote(str(out_dir))}"
             if (out_dir / CHECKPOINT).exists() or (out_dir / FINAL_CHECKPOINT).exists()
             else "run it again with --overwrite (no checkpoint was written)")
    return OutputError(f"{out_dir}: {exc.strerror} writing {exc.filename or 'the frames'}"
                       f"{where}: free space (or save fewer frames: [output] every, --no-vtu), "
                       f"then {again}")
