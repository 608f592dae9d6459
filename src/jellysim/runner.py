"""Run a scene: build, simulate frame by frame, stream frames to disk, write outputs.

Outputs in ``out_dir``: ``trajectory.npz`` (see :mod:`jellysim.io.trajectory`) and, unless
disabled, the ParaView series ``body.pvd`` + ``body_NNNNN.vtu`` (and ``skin.pvd`` +
``skin_NNNNN.vtu`` when the body carries a skin, see :mod:`jellysim.skin`).

Frames go to disk as they are produced (``trajectory.stream/``, :mod:`jellysim.io.stream`):
memory does not grow with the frame count, and a run stopped at any moment leaves every
flushed frame readable.  When the run ends the stream becomes ``trajectory.npz``.  If the run
goes unstable, the frames so far are kept (``status = "failed: ..."``) and the
:class:`~jellysim.errors.SimulationError` is re-raised.  SIGINT / SIGTERM finish the current
frame, write a checkpoint (``checkpoint.npz``, :mod:`jellysim.io.checkpoint`) and raise
:class:`~jellysim.errors.RunInterrupted`; ``run_scene(..., resume=True)`` continues from the
last checkpoint bit-identically.
"""
from __future__ import annotations

import fnmatch
import os
import shlex
import signal
import sys
import threading
import time
import warnings
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

from .errors import (BuildError, CheckpointError, JellysimError, NothingToResume, OutputError,
                     ParameterError, RunInterrupted, SimulationError)
from .io.checkpoint import (CHECKPOINT, FINAL_CHECKPOINT, mpiexec_interruption,
                            read_checkpoint, write_checkpoint)
from .io.lock import LOCK_NAME, claim, refuse_if_held
from .io.stream import (STREAM_DIR, TrajectoryStream, finalize_stream, reopen_stream,
                        stream_frames, stream_steps)
from .io.trajectory import load_trajectory, skin_bounds, trajectory_meta
from .run_disk import _check_disk, _disk_full, _vtu_frame_bound
from .run_notes import _resume_command, _say_if_slow
from .io.vtk import FrameWriter, PVDSeries
from .physics.fem import stress_fields
from .handles import handle_fields
from .handle_paths import aliasing_notes
from .skin import default_skin

__all__ = ["RUN_FILES", "RunResult", "prepare_out_dir", "run_scene",
           "AUTO_CHECKPOINT_SECONDS"]

AUTO_CHECKPOINT_SECONDS = 60.0
"""Without ``[output] checkpoint_every``: a checkpoint at the first frame after this much
wall-clock time since the last one."""


RUN_FILES = ("trajectory.npz", "body.pvd", "body_[0-9]*.vtu", "skin.pvd", "skin_[0-9]*.vtu",
             ".trajectory.npz.*", ".body*", ".skin*", "checkpoint.npz", "checkpoint.final.npz")
"""Names (glob patterns) of the files a run writes into its folder: what ``--overwrite``
removes before a new run (nothing else in the folder is touched)."""


def holds_unfinished_run(out_dir) -> bool:
    """Whether ``out_dir`` holds a run that started and did not finish (interrupted, killed,
    or running): its checkpoint or its frame stream."""
    out_dir = Path(out_dir)
    return (out_dir / CHECKPOINT).exists() or (out_dir / STREAM_DIR).is_dir()


def prepare_out_dir(out_dir, *, overwrite: bool = False, owned=RUN_FILES,
                    option: str = "--out", delete: bool = True, held: bool = False) -> Path:
    """Make ``out_dir`` ready for a run: create it; if it already holds files, refuse
    (:class:`~jellysim.errors.JellysimError`) unless ``overwrite``, and then delete the files
    an earlier run wrote there (names matching ``owned``), so no stale frame survives.
    Files that are not a run's are kept; ``delete=False`` only checks (the caller deletes
    once the new run is known to start).  A live run writing there is refused first
    (:func:`jellysim.io.lock.refuse_if_held`; ``held``: the caller holds the folder's lock).
    Returns the folder."""
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise JellysimError(f"{option} {out_dir}: exists and is not a folder")
    if out_dir.is_dir() and not held:
        refuse_if_held(out_dir)
    # (a live run's lock was refused above: what is left is this run's own or a killed
    # run's, which says nothing of a run's files: sweep trial, session 30, a folder holding
    # only a dead worker's lock was called "not empty")
    present = sorted(p for p in out_dir.iterdir() if p.name != LOCK_NAME) if (
        out_dir.is_dir()) else []
    if present and not overwrite:
        names = ", ".join(p.name for p in present[:3]) + (", ..." if len(present) > 3 else "")
        quoted = shlex.quote(str(out_dir))
        if holds_unfinished_run(out_dir):
            raise JellysimError(f"{option} {out_dir}: holds an interrupted run; continue it with "
                                f"--resume {quoted} (and no {option}), or pass --overwrite to "
                                f"replace it (its frames so far are lost), or choose another "
                                f"{option}")
        more = (f"; --resume {quoted} --steps N extends it"
                if (out_dir / FINAL_CHECKPOINT).exists() else "")
        status = _status(out_dir / "trajectory.npz")
        if status.startswith("interrupted") and "mpiexec" in status:
            more = ("; it holds a run interrupted under mpiexec at step "
                    f"{status.split()[3]} (no checkpoint: it cannot be resumed)")
        raise JellysimError(f"{option} {out_dir}: the folder is not empty ({len(present)} "
                            f"entries: {names}); pass --overwrite to replace the run there, "
                            f"or choose another {option}{more}")
    # what says "a run is here" goes first (trajectory, checkpoints, stream), the series
    # next, the frames last: a delete killed half-way (SIGKILL) leaves loose frames, never a
    # "complete" trajectory beside a part of its frames (the reliability trial)
    first = ("trajectory.npz", CHECKPOINT, FINAL_CHECKPOINT, STREAM_DIR, f"{STREAM_DIR}.partial")
    present.sort(key=lambda p: (p.name not in first, not p.name.endswith(".pvd"), p.name))
    for p in present if delete else ():
        if p.is_file() and any(fnmatch.fnmatchcase(p.name, pat) for pat in owned):
            p.unlink()
        elif p.is_dir() and p.name in (STREAM_DIR, f"{STREAM_DIR}.partial"):  # its frames
            import shutil

            shutil.rmtree(p)
    out_dir.mkdir(parents=True, exist_ok=True)
    return out_dir


@dataclass
class RunResult:
    out_dir: Path
    trajectory: Path
    pvd: Path | None
    frames: int
    steps: int
    seconds: float
    """Wall-clock time of the stepping alone [s]."""
    warnings: list[str] = field(default_factory=list)
    resumed_from: int | None = None
    """Step of the checkpoint the run continued from (``resume=True``), else ``None``."""
    simulated: float = 0.0
    """Simulated time this call stepped [s] (its steps x the frame step ``dt``)."""
    thread_steps: dict[int, int] = field(default_factory=dict)
    """Steps run on each thread count (``{threads: steps}``: ``Simulator.thread_steps``)."""
    first_chunk: tuple[int, float] | None = None
    """Steps and wall-clock seconds of the first ``advance`` call (on a first run they include
    numba compiling the kernels, which later runs load from its cache)."""

    def startup_seconds(self) -> float:
        """How much longer the first ``advance`` call took than the later calls' pace [s]:
        numba's compilation on a first run (0 when there is nothing to compare with)."""
        if self.first_chunk is None:
            return 0.0
        steps, seconds = self.first_chunk
        later_steps = self.steps - (self.resumed_from or 0) - steps
        later_seconds = self.seconds - seconds
        if later_steps <= 0 or later_seconds <= 0:
            return 0.0
        return max(0.0, seconds - steps * later_seconds / later_steps)


def refuse_earlier_run(out_dir: Path, overwrite: bool, option: str = "overwrite=True") -> None:
    """An earlier run's files in ``out_dir`` (:data:`RUN_FILES`): an
    :class:`~jellysim.errors.OutputError` unless ``overwrite`` (the caller deletes them once
    the new run is known to start: ``prepare_out_dir(..., overwrite=True, held=True)``)."""
    earlier = _earlier_run(out_dir)
    if earlier and not overwrite:
        names = ", ".join(earlier[:3]) + (", ..." if len(earlier) > 3 else "")
        status = _status(out_dir / "trajectory.npz") if "trajectory.npz" in earlier else ""
        if status.startswith("interrupted") and "mpiexec" in status:
            raise OutputError(f"{out_dir}: holds a run interrupted under mpiexec at step "
                              f"{status.split()[3]} (no checkpoint: it cannot be resumed); "
                              f"pass {option} to run it afresh, or choose another folder")
        raise OutputError(f"{out_dir}: holds an earlier run ({names}); pass {option} to "
                          "replace it" + (", resume=True to continue it" if option ==
                                          "overwrite=True" else "") + ", or choose another "
                          "folder")


def _earlier_run(out_dir: Path) -> list[str]:
    """Names of an earlier run's files in ``out_dir`` (:data:`RUN_FILES`, its frame stream)."""
    return sorted(p.name for p in out_dir.iterdir()
                  if (p.is_file() and any(fnmatch.fnmatchcase(p.name, pat) for pat in RUN_FILES))
                  or (p.is_dir() and p.name in (STREAM_DIR, f"{STREAM_DIR}.partial")))


def _clean(out_dir: Path) -> None:
    """Remove what an earlier killed run may have left half-written: ``*.partial`` files
    and the hidden temporaries of atomic writes of the run's own outputs."""
    for pattern in ("*.partial", f"{STREAM_DIR}/*.partial", ".trajectory.npz.*",
                    ".body_*.vtu.*", ".skin_*.vtu.*", ".body.pvd.*", ".skin.pvd.*"):
        for p in out_dir.glob(pattern):
            if p.is_file():
                p.unlink()
    partial = out_dir / f"{STREAM_DIR}.partial"  # a finished run's stream, half reopened
    if partial.is_dir():
        import shutil

        shutil.rmtree(partial)


def _earlier_files(out_dir: Path) -> list[Path]:
    """The files of an earlier run in ``out_dir`` (what ``overwrite`` deletes)."""
    out = []
    for name in _earlier_run(out_dir):
        p = out_dir / name
        out += [q for q in p.rglob("*") if q.is_file()] if p.is_dir() else [p]
    return out


def run_scene(scene, out_dir, *, progress: bool = True, vtu: bool | None = None,
              steps: int | None = None, skin="auto", body=None, resume: bool = False,
              checkpoint_every: int | None = None, stop_after: int | None = None,
              handle_signals: bool = True, overwrite: bool = False,
              notify=None) -> RunResult:
    """Simulate ``scene`` (a :class:`~jellysim.scene.Scene`) and write its outputs.

    ``progress``: show a progress bar (rich) while stepping, and say when the body is settled.
    ``vtu``: write the ParaView series (``body.pvd`` + ``.vtu`` frames); ``None`` (default):
    the scene's ``[output] vtu`` (with ``resume``: the run's own choice).
    ``steps``: the run's total number of time steps (a resume or extension runs on to it),
    overriding ``[integrator] steps``; ``None`` (default): the scene's (with ``resume``: the
    count the run was started with, when the scene's is unchanged).
    ``skin``: a :class:`~jellysim.skin.Skin` to carry, ``None`` for none, or ``"auto"``
    (:func:`jellysim.skin.default_skin`: the box surface for box scenes).
    ``body``: a :class:`~jellysim.body.Body` to simulate instead of the scene's own.
    ``resume``: continue the run in ``out_dir`` from its checkpoint (same scene; validated),
    or extend a finished run from its end state when more ``steps`` are asked (else
    :class:`~jellysim.errors.NothingToResume`).
    ``checkpoint_every``: steps between checkpoints (overrides ``[output] checkpoint_every``;
    0: only when interrupted).
    ``stop_after``: stop (checkpoint, :class:`RunInterrupted`) at the first frame once this
    many steps are done, e.g. to split a long run into jobs.
    ``handle_signals``: catch SIGINT/SIGTERM (main thread only) to stop cleanly.
    ``notify``: called with each warning of the build (mesh units, open surfaces, the
    trajectory's size) before the stepping starts; they are also in ``RunResult.warnings``.
    ``overwrite``: an earlier run's files in ``out_dir`` (:data:`RUN_FILES`) are refused
    (:class:`~jellysim.errors.OutputError`: nothing is touched) unless this is true, and then
    deleted first so none of its frames survives; other files there are kept.
    A live run already writing ``out_dir`` (its lock file, :mod:`jellysim.io.lock`) makes this
    an :class:`~jellysim.errors.OutputError`."""
    if isinstance(scene, (str, os.PathLike)):  # a scene file's path
        from .scene import Scene

        scene = Scene.from_file(scene)
    elif not hasattr(scene, "params"):
        raise ParameterError(f"run_scene: scene must be a jellysim Scene (Scene.from_file(path)"
                             f") or a scene file's path, got {type(scene).__name__}")
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise OutputError(f"{out_dir}: exists and is not a folder; choose another output folder")
    created = not out_dir.exists()
    out_dir.mkdir(parents=True, exist_ok=True)
    lock = claim(out_dir)  # before anything there is touched: one run per folder
    try:
        if not resume:  # (its files go once the new run's body and simulator are made)
            refuse_earlier_run(out_dir, overwrite)
        return _run(scene, out_dir, progress=progress, vtu=vtu, steps=steps, skin=skin,
                    body=body, resume=resume, checkpoint_every=checkpoint_every,
                    stop_after=stop_after, handle_signals=handle_signals, notify=notify)
    except OSError as exc:  # a full disk outside the stepping (the first frame, the end)
        full = _disk_full(exc, out_dir, scene)
        if full is None:
            raise
        raise full from None
    finally:
        lock.unlink(missing_ok=True)
        if created and not any(out_dir.iterdir()):  # refused before anything was written
            out_dir.rmdir()


def _asked(params: dict, total: int) -> dict:
    """The scene's parameters as the run records them: ``[integrator] steps`` the steps the
    run was asked for (``--steps`` / ``steps=`` overrides the scene's)."""
    if params.get("integrator", {}).get("steps") == total:
        return params
    return {**params, "integrator": {**params["integrator"], "steps": int(total)}}


def _asked_text(scene, total: int) -> str:
    """The scene's text as the run records it: with a closing comment when the run was asked
    for another number of steps than the scene's (``--steps``)."""
    if scene.params.get("integrator", {}).get("steps") == total:
        return scene.text
    return scene.text.rstrip("\n") + f"\n# run for {int(total)} steps (--steps)\n"


def _status(npz_path) -> str:
    """The ``status`` a saved trajectory records ("" when it cannot be read)."""
    try:
        return str(load_trajectory(npz_path, mmap=True).status or "")
    except (JellysimError, OSError, ValueError):
        return ""


def finished_run(out_dir) -> bool:
    """Whether ``out_dir`` holds a completed (or failed) run: its ``trajectory.npz`` and
    neither a stream nor a checkpoint of a run still to finish."""
    out_dir = Path(out_dir)
    return ((out_dir / "trajectory.npz").exists() and not (out_dir / CHECKPOINT).exists()
            and not (out_dir / STREAM_DIR).exists())


def _run(scene, out_dir: Path, *, progress, vtu, steps, skin, body, resume, checkpoint_every,
         stop_after, handle_signals, notify=None) -> RunResult:
    """:func:`run_scene` in a folder this process holds."""
    _clean(out_dir)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            if body is None and scene.params["body"]["type"] == "mesh":
                from . import _warmup  # compile the step beside the mesh's sampling

                _warmup.start(scene.params)
            model = scene.build_model(body)
            settling = progress and not resume and bool(scene.params["body"].get("settle"))
            if settling:  # (it can take a while: say so)
                print("settling the body at rest before t = 0 ([body] settle) ...",
                      file=sys.stderr, flush=True)
            start = time.perf_counter()
            sim = scene.simulator(model, settle=not resume)  # (a resume restores the state)
            if settling:
                print(f"settling took {time.perf_counter() - start:.3g} s of wall time",
                      file=sys.stderr, flush=True)
        except JellysimError as exc:  # what the build said may explain it (mesh units)
            exc.run_warnings = [str(w.message) for w in caught]
            raise
    messages = [str(w.message) for w in caught]
    if isinstance(skin, str) and skin == "auto":
        try:
            skin = default_skin(scene, model.body)
        except BuildError as exc:
            messages.append(f"no skin: {exc}")
            skin = None
    total = scene.steps if steps is None else int(steps)
    every = scene.frame_every
    messages += aliasing_notes(scene.params.get("handle"), every * sim.dt)
    if checkpoint_every is None:
        checkpoint_every = scene.params["output"].get("checkpoint_every")
    write_vtu = scene.params["output"]["vtu"] if vtu is None else vtu
    freed = 0 if resume else sum(p.stat().st_size for p in _earlier_files(out_dir))
    try:  # (frames already on disk; a damaged stream is said below)
        have = stream_frames(out_dir / STREAM_DIR) if resume else 0
    except (OSError, ValueError):
        have = 0
    _check_disk(out_dir, total, every, model.point_count, messages, freed=freed, have=have,
                frame_bytes=_vtu_frame_bound(model, skin) if write_vtu else 0)
    for m in dict.fromkeys(messages) if notify is not None else ():
        notify(m)
    stream_dir = out_dir / STREAM_DIR
    ckpt_path = out_dir / CHECKPOINT
    npz_path = out_dir / "trajectory.npz"
    body = model.body
    resumed_from = None
    final_path = out_dir / FINAL_CHECKPOINT
    extending = False
    if resume:
        finished = finished_run(out_dir)
        if finished and not final_path.exists():
            interrupted = mpiexec_interruption(out_dir, _status(npz_path))
            if interrupted:  # (not finished: an error, as a lost checkpoint is)
                raise CheckpointError(interrupted)
            extend = steps is not None or any(o.partition("=")[0].strip() == "integrator.steps"
                                              for o in getattr(scene, "overrides", ()))
            raise (CheckpointError if extend else NothingToResume)(  # (more asked: an error)
                f"{out_dir}: {'cannot extend' if extend else 'nothing to resume'}: the run has "
                f"finished ({npz_path}) and kept no final state to extend it from (it ran "
                "under mpiexec, whose runs keep none, or it failed, or an older jellysim "
                "wrote it); run it again with --overwrite (and the steps asked)")
        # the steps the stream's run asked (an extension's own), read now: a damaged stream
        # is said before a step is taken, not after all of them
        asked = stream_steps(stream_dir) if stream_dir.exists() else None
        # an extension interrupted before its first checkpoint continues from the final state
        from_final = not ckpt_path.exists() and final_path.exists()
        ck = read_checkpoint(final_path if from_final else ckpt_path, scene=scene, model=model)
        steps_set = any(o.partition("=")[0].strip() == "integrator.steps"
                        for o in getattr(scene, "overrides", ()))
        if (steps is None and ck.total_steps is not None and not steps_set
                and scene.steps == ck.scene_steps):
            total = ck.total_steps  # finish the run that was asked (its --steps)
            if from_final and asked is not None:  # an extension killed before its first
                total = max(total, asked)          # checkpoint: its own steps
        if finished and total <= ck.step:
            raise NothingToResume(
                f"{out_dir}: nothing to resume: the run has finished at step {ck.step} "
                f"(t = {ck.t:.6g} s); to extend it ask for more steps: --steps N (Python: "
                f"steps=N) or --set integrator.steps=N with N > {ck.step}")
        if total < ck.step:
            raise CheckpointError(f"{out_dir}: the checkpoint is at step {ck.step}, past the "
                                  f"{total} steps asked; resume with --steps {ck.step} or "
                                  "more (the interrupted run asked "
                                  f"{ck.total_steps if ck.total_steps is not None else '?'})")
        if ck.frame_every is not None:
            every = ck.frame_every  # frames keep the run's schedule, whatever its new length
        if have > total // every + 1 + (1 if total % every else 0):  # (asked: said, not silent)
            told = (f"{out_dir}: {have} frames are on disk and {total} steps asked end before "
                    f"the last of them: those past step {total} are dropped")
            notify(told) if notify is not None else warnings.warn(told, stacklevel=3)
        if vtu is None and ck.vtu is not None:
            write_vtu = ck.vtu  # an extension keeps the run's --no-vtu
        elif not write_vtu and ck.vtu:  # (asked: --no-vtu on a run that wrote its series)
            told = (f"{out_dir}: resumed without .vtu frames (--no-vtu): its ParaView series "
                    f"body.pvd ends at t = {ck.t:.6g} s while trajectory.npz goes on; "
                    f"`jellysim export {out_dir} -o FILE.pvd` writes the whole series")
            notify(told) if notify is not None else warnings.warn(told, stacklevel=3)
        if not stream_dir.exists():  # a finished run being extended: its frames back
            if not npz_path.exists():
                raise CheckpointError(f"{out_dir}: the run's frames are gone (no {npz_path.name}"
                                      f" and no {STREAM_DIR}): it cannot be extended; run it "
                                      "again with --overwrite")
            try:
                reopen_stream(npz_path, stream_dir, meta=trajectory_meta(
                    model, scene_text=_asked_text(scene, total),
                    params=_asked(scene.params, total), skin=skin))
            except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
                _clean(out_dir)  # (the half-reopened stream)
                raise CheckpointError(f"{npz_path}: damaged ({exc}: cut short?): the run cannot "
                                      "be extended; run it again with --overwrite") from None
        s = sim.state
        s.x[:], s.v[:], s.a[:] = ck.x, ck.v, ck.a
        s.t, s.step = ck.t, ck.step
        sim.restore_internal_state(ck.internal)
        # the finished run's last frame lies off the schedule when its steps were no multiple
        # of `every`: dropped, so the extension's frames are the longer run's
        keep = ck.frames - 1 if from_final and ck.step % every else ck.frames
        try:
            stream = TrajectoryStream(stream_dir, model.point_count, keep=keep)
        except (OSError, ValueError) as exc:
            raise CheckpointError(f"{stream_dir}: cannot continue the trajectory stream "
                                  f"({exc}); start afresh without --resume") from None
        resumed_from = ck.step
        extending = final_path.exists()  # (a fresh run deletes it: this folder's run had ended)
    else:  # the new run starts: an earlier run's files go now (refused unless overwrite,
        prepare_out_dir(out_dir, overwrite=True, held=True)  # in run_scene), none before
        for stale in (npz_path, ckpt_path, final_path):
            if stale.exists():
                stale.unlink()
        meta = trajectory_meta(model, scene_text=_asked_text(scene, total),
                               params=_asked(scene.params, total), skin=skin)
        stream = TrajectoryStream(stream_dir, model.point_count, meta)
        keep = None
    series = PVDSeries(out_dir, keep=keep) if write_vtu else None
    skin_series = (PVDSeries(out_dir, "skin", keep=keep)
                   if write_vtu and skin is not None else None)
    bounds = skin_bounds(scene.params)  # the ground and obstacles the skin is kept out of

    physical = getattr(model, "fem", None) is not None
    tets = model.fem.tets if physical else body.tets
    # a tet body's ParaView cells are its tets alone (colour them by volume_ratio); a springs
    # body's are its springs (and its tets, if it has some)
    lines = model.spring_ij[:0] if physical else model.spring_ij

    writer = FrameWriter()  # the .vtu frames, written beside the run (io/vtk.py)

    def emit():
        stream.record(sim.state)
        if series is not None:  # (a physical body's tets carry their stress [Pa])
            writer.submit(sim.state.step, series.add, sim.state.t, sim.state.x.copy(),
                          lines, velocities=sim.state.v.copy(), rest=model.point_x0,
                          tets=tets, triangles=None if physical else body.triangles,
                          tet_fields=stress_fields(sim.tet_stresses()) if physical else None,
                          point_fields=handle_fields(sim))
        if skin_series is not None:
            writer.submit(sim.state.step, skin_series.add_surface, sim.state.t,
                          skin.deform(sim.state.x, **bounds), skin.faces)

    def checkpoint():
        writer.flush()  # (the checkpoint counts the series' frames: all on disk first)
        write_checkpoint(ckpt_path, sim, frames=stream.frames, scene=scene, model=model,
                         total=total, every=every, vtu=write_vtu)

    done = sim.state.step
    if not resume:
        emit()
        if checkpoint_every != 0:
            checkpoint()  # a killed run can always be resumed, from its start at least
    stepped = 0.0
    first = None  # (steps, seconds) of the first advance call
    bar, told, began = None, False, done
    stop: list[int | None] = [None]
    previous_handlers = {}
    if handle_signals and threading.current_thread() is threading.main_thread():
        def on_signal(signum, frame):
            if stop[0] is not None:
                raise KeyboardInterrupt  # a second signal: stop at once
            stop[0] = signum

        for sig in (signal.SIGINT, signal.SIGTERM):
            previous_handlers[sig] = signal.signal(sig, on_signal)
    if progress:
        from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn,
                                   TimeElapsedColumn, TimeRemainingColumn)

        bar = Progress(TextColumn("[bold]simulating"), BarColumn(), MofNCompleteColumn(),
                       TextColumn("steps"), TimeElapsedColumn(), TextColumn("elapsed,"),
                       TimeRemainingColumn(), TextColumn("left"), transient=False)
        bar.start()
        task = bar.add_task("run", total=total, completed=min(done, total))
    last_wall, last_step = time.monotonic(), done
    during = warnings.catch_warnings(record=True)
    caught = during.__enter__()
    warnings.simplefilter("always")
    try:
        try:
            while done < total:
                n = min(every - done % every, total - done)  # frames stay on multiples
                t0 = time.perf_counter()
                try:
                    sim.advance(n)
                finally:
                    stepped += time.perf_counter() - t0
                    first = (n, stepped) if first is None else first
                done += n
                emit()
                if bar is not None:
                    bar.update(task, completed=done)
                    choosing = not getattr(getattr(sim, "_thread_choice", None), "chosen", 1)
                    if not told and choosing:  # the pace counts from the threads' choice
                        first = (done - began, stepped)
                    elif not told and done - began > first[0]:  # the pace after the first
                        told = _say_if_slow(notify, sim, stepped - first[1],  # (compiling)
                                            done - began - first[0], total - done)
                if done >= total:
                    break
                if stop[0] is not None or (stop_after is not None and done >= stop_after):
                    checkpoint()
                    how = (f"interrupted by {signal.Signals(stop[0]).name}"
                           if stop[0] is not None else f"stopped after {done} steps as asked")
                    stream.set_status(f"interrupted at step {done} ({how}); resumable")
                    raise RunInterrupted(
                        f"{how} at step {done} of {total} (t = {sim.state.t:.6g} s); "
                        f"{stream.frames} frames saved in {stream_dir} (jellysim render, "
                        f"plot and export read it: pass {shlex.quote(str(out_dir))}); continue "
                        f"with: {_resume_command(scene, out_dir)}",
                        step=done, signal=stop[0], out_dir=out_dir)
                if checkpoint_every is None:
                    due = time.monotonic() - last_wall >= AUTO_CHECKPOINT_SECONDS
                else:
                    due = checkpoint_every > 0 and done - last_step >= checkpoint_every
                if due:
                    checkpoint()
                    last_wall, last_step = time.monotonic(), done
            writer.flush()
        except OSError as exc:  # a full disk, most likely: say where and how to go on
            done = getattr(exc, "frame_tag", done)  # (a .vtu frame written behind the run)
            full = _disk_full(exc, out_dir, scene, f" at step {done} of {total}")
            if full is None:
                raise
            try:
                stream.set_status(f"stopped at step {done}: {exc.strerror}; resumable")
            except OSError:
                pass
            raise full from None
        except SimulationError as exc:
            emit()
            writer.flush()
            stream.close()
            finalize_stream(stream_dir, npz_path, status=f"failed: {exc}")
            # a failed run is not extended; a failed extension keeps the end state it started
            # from (extending again cuts the stream back to that run's frames)
            for stale in (ckpt_path,) if extending else (ckpt_path, final_path):
                if stale.exists():
                    stale.unlink()
            # what was said before it failed (a stability warning often explains the failure)
            exc.run_warnings = messages + [str(w.message) for w in caught]
            raise
    finally:
        writer.close()
        during.__exit__(None, None, None)
        messages += [str(w.message) for w in caught]
        for sig, handler in previous_handlers.items():
            signal.signal(sig, handler)
        if bar is not None:
            bar.stop()
        stream.close()
    frames = stream.frames
    # the end state first (so `--resume --steps N` can extend the run), then the .npz
    write_checkpoint(final_path, sim, frames=frames, scene=scene, model=model, total=total,
                     every=every, vtu=write_vtu)
    if ckpt_path.exists():  # (a resume now only copies the frames: none is simulated again)
        ckpt_path.unlink()
    try:
        path = finalize_stream(stream_dir, npz_path, status="complete")
    except OSError as exc:  # (a full disk while copying the frames into the .npz)
        npz_path.with_name(npz_path.name + ".partial").unlink(missing_ok=True)
        full = _disk_full(exc, out_dir, scene, f" (all {total} steps done, copying the frames"
                          f" into {npz_path.name})")
        if full is None:
            raise
        raise full from None
    return RunResult(out_dir, path, series.pvd_path if series else None,
                     frames, total, stepped, messages, resumed_from,
                     simulated=(total - (resumed_from or 0)) * float(sim.dt),
                     first_chunk=first, thread_steps=dict(getattr(sim, "thread_steps", {})))
