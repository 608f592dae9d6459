"""Write rendered frames as MP4 (H.264), GIF or a folder of PNG pictures."""
from __future__ import annotations

import contextlib
from pathlib import Path

import numpy as np

from ..errors import JellysimError
from ..io.atomic import atomic_path, guard_file, guard_folder, staged_output
from ..io.timing import default_fps, gif_delay, real_time_playback
from .offscreen import RenderOptions, Renderer

__all__ = ["default_fps", "render_trajectory", "output_kind"]


def output_kind(path) -> str:
    """``"mp4"``, ``"gif"``, ``"png"`` or ``"jpg"`` (one picture) or ``"pngdir"`` (a folder
    of frames)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in (".mp4", ".m4v", ".mov"):
        return "mp4"
    if suffix == ".gif":
        return "gif"
    if suffix == ".png":
        return "png"
    if suffix in (".jpg", ".jpeg"):
        return "jpg"
    if suffix == "":
        return "pngdir"
    raise JellysimError(f"{path}: unknown picture/video type '{suffix}'; use .mp4, .gif, "
                        ".png or .jpg (one frame) or a folder name (PNG frames)")


class _SideBySide:
    """Renderers of several runs as one: frame ``f`` of the first, and of each other its
    frame nearest in time (the last once it has ended), side by side."""

    def __init__(self, renderers):
        self.renderers = renderers

    def render(self, f: int) -> np.ndarray:
        t = float(self.renderers[0].traj.times[f])
        images = []
        for r in self.renderers:
            times = np.asarray(r.traj.times, dtype=np.float64)
            images.append(r.render(int(np.argmin(np.abs(times - t)))))
        return np.concatenate(images, axis=1)


def _frames_with_progress(renderer, frames, progress: bool, label: str):
    bar = None
    if progress:
        from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn,
                                   TimeElapsedColumn, TimeRemainingColumn)

        bar = Progress(TextColumn(f"[bold]{label}"), BarColumn(), MofNCompleteColumn(),
                       TextColumn("frames"), TimeElapsedColumn(), TextColumn("elapsed,"),
                       TimeRemainingColumn(), TextColumn("left"))
        bar.start()
        task = bar.add_task(label, total=len(frames))
    done = 0
    try:
        for f in frames:
            image = renderer.render(int(f))
            done += 1  # (counted when drawn: a caller that stops after the last one
            yield image  # never resumes the generator, which left "6/7 frames")
            if bar is not None:
                bar.update(task, completed=done)
    finally:
        if bar is not None:
            bar.update(task, completed=done)
            bar.stop()


def _gif_delays(times, frames, fps: float, real_time: bool) -> list[float]:
    """Each GIF frame's delay [ms]: whole hundredths of a second, at least 2 (browsers slow
    shorter ones; Pillow truncates 29.999 ms to 20).  In real time the delays follow the
    frames' simulated times, rounded as a running total (a 30 frames/s run: 3, 3, 4, 3, 3, 4
    hundredths, not 3 throughout, which played 10 % fast); the last frame gets one step."""
    step = gif_delay(fps)
    if not real_time or len(frames) < 2:
        return [10.0 * step] * len(frames)
    t = np.asarray(times, dtype=np.float64)[np.asarray(frames)]
    hundredths = np.maximum(np.diff(np.round((t - t[0]) * 100.0)), 2)
    return [10.0 * float(d) for d in hundredths] + [10.0 * step]


FRAME_FILES = "frame_[0-9]*.png"
"""The files of a rendered folder of frames (:func:`render_trajectory`)."""


def render_trajectory(traj, path, options: RenderOptions = RenderOptions(), *,
                      fps: float | None = None, frames=None, progress: bool = False,
                      beside=(), labels=None, name: str | None = None,
                      overwrite: bool = False) -> Path:
    """Render a loaded trajectory to ``path``.

    Parameters
    ----------
    traj: a :class:`~jellysim.io.trajectory.Trajectory` (only read).
    path: ``.mp4`` (H.264, yuv420p), ``.gif``, ``.png`` (one picture: the last of ``frames``)
        or a folder (``frame_00000.png``, ...).
    options: :class:`RenderOptions`.
    fps: frames per second (default: real time, :func:`~jellysim.io.timing.real_time_playback`:
        a run saved faster than 60 frames/s, 50 for a GIF, shows every k-th of ``frames``).
    frames: trajectory frame indices to draw (default: all).
    progress: show a progress bar.
    beside: more trajectories drawn to the right of ``traj``, each at its frame nearest in
        time to ``traj``'s (its last once it has ended), all panels framed by one camera at
        one scale (side by side: soft vs firm, damped vs not).
    labels: a caption per panel (``traj``'s first), or ``None``.
    name: what the progress bar says is rendered (default: ``path``'s name).
    overwrite: replace an existing file, or a folder's earlier ``frame_*.png`` (all of them,
        once the new frames are written: none left to mix); without it those are refused
        (:class:`~jellysim.errors.OutputError`), as by ``jellysim render`` (notebook trial,
        session 30: a second render replaced the first unsaid, and a folder of frames mixed
        two renders).  A file is written under a temporary name and renamed, a folder's
        frames staged: an interrupted render leaves the earlier output whole.
    """
    path = Path(path)
    kind = output_kind(path)
    if traj.frame_count == 0:
        raise JellysimError("the trajectory has no frames to render")
    frames = np.arange(traj.frame_count) if frames is None else np.asarray(frames, dtype=int)
    if len(frames) == 0 or frames.min() < -traj.frame_count or (
            frames.max() >= traj.frame_count):
        raise JellysimError(f"frames must lie in [0, {traj.frame_count - 1}]")
    real_time = fps is None
    if fps is None and kind in ("mp4", "gif"):  # real time: every k-th frame of a run saved
        frames, fps = real_time_playback(traj.times, frames, gif=kind == "gif")  # faster
    fps = 30.0 if fps is None else float(fps)  # (pictures: every frame asked, no rate)
    if not fps > 0:
        raise JellysimError(f"fps must be > 0, got {fps}")
    played = 100.0 / gif_delay(fps)
    if kind == "gif" and abs(played - fps) > 0.01 * fps:
        import warnings

        warnings.warn(f"{path}: a GIF's frame delays are whole hundredths of a second (at "
                      f"least 2, or browsers slow them): fps = {fps:g} plays at {played:.4g} "
                      "frames/s", UserWarning, stacklevel=2)
    if not real_time and kind in ("mp4", "gif") and len(frames) > 1:
        step = float(np.median(np.diff(np.asarray(traj.times)[frames])))
        if step > 0 and abs(fps * step - 1.0) > 0.01:  # (said: session 14's trial took
            import warnings                            # --fps 24 for a resampling)

            warnings.warn(f"{path}: each saved frame is shown once at fps = {fps:g}: the run "
                          f"(a frame every {step:.4g} s) plays at {fps * step:.3g}x real time; "
                          "leave out --fps for real time", UserWarning, stacklevel=2)
    if kind in ("png", "jpg"):
        frames = frames[-1:]
    if options.background == "transparent" and kind not in ("png", "pngdir"):
        raise JellysimError(f"{path}: a transparent background needs PNG output (a .png or a "
                            f"folder of frames): {kind} has no alpha channel")
    if kind == "pngdir":  # (checked before anything is drawn: a refusal costs nothing)
        guard_folder(path, [FRAME_FILES], overwrite, flag="overwrite=True")
    else:
        guard_file(path, overwrite, flag="overwrite=True")
    runs = [traj, *beside]
    labels = list(labels) if labels is not None else [None] * len(runs)
    with contextlib.ExitStack() as opened:  # every renderer closed, whatever happens
        renderers = [opened.enter_context(Renderer(
            t, options, frame_with=[u for u in runs if u is not t] if beside else (),
            label=labels[k])) for k, t in enumerate(runs)]
        r = renderers[0] if not beside else _SideBySide(renderers)
        images = _frames_with_progress(r, frames, progress,
                                       f"rendering {name or path.name}")
        if kind == "mp4":
            import imageio.v2 as iio

            with atomic_path(path) as tmp:
                writer = iio.get_writer(tmp, format="FFMPEG", mode="I", fps=fps,
                                        codec="libx264", pixelformat="yuv420p",
                                        macro_block_size=1, quality=8,
                                        ffmpeg_log_level="error")
                try:
                    for img in images:
                        writer.append_data(img)
                finally:
                    writer.close()
        elif kind == "gif":
            import imageio.v3 as iio

            stack = np.stack(list(images))
            with atomic_path(path) as tmp:
                iio.imwrite(tmp, stack, extension=".gif", loop=0,
                            duration=_gif_delays(traj.times, frames, fps, real_time))
        elif kind in ("png", "jpg"):
            import imageio.v3 as iio

            with atomic_path(path) as tmp:
                iio.imwrite(tmp, next(iter(images)), extension=f".{kind}",
                            **({"quality": 95} if kind == "jpg" else {}))
        else:
            import imageio.v3 as iio

            with staged_output(path, [FRAME_FILES]) as stage:  # (old frames go at the end)
                for i, img in zip(frames, images):  # named by the run's frame number
                    iio.imwrite(stage / f"frame_{int(i) % traj.frame_count:05d}.png", img,
                                extension=".png")
    return path
