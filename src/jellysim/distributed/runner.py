"""``mpiexec -n N jellysim run scene.toml``: the scene run of :mod:`jellysim.runner` on ranks.

Rank 0 builds the body and the Model from the scene (so builders and calibration need not be
deterministic across processes) and the partition, and broadcasts them; every rank steps its
part (:class:`~.simulator.DistributedSimulator`); at each frame the state is gathered on rank 0,
which records it, writes the ParaView frame and at the end the one ``trajectory.npz`` (the
same files as a serial run; fine while one frame of the whole body fits in rank 0's memory).
Rank 0 prints progress.  An error on one rank only is printed with the rank's number and the
whole job is aborted (``MPI_Abort``), so the other ranks do not wait for it.  A Ctrl-C or
SIGTERM while the ranks step stops them all at the next frame (:class:`StoppedTogether`: the
frames so far saved, exit 130, no abort); one while rank 0 builds the body reaches every rank
through :func:`~.simulator.on_root` (:class:`~.simulator.AllStopped`, exit 130); a second one
aborts the job.
"""
from __future__ import annotations

import sys
import time
import traceback
import warnings
from pathlib import Path

from ..errors import BuildError, JellysimError, SceneError, SimulationError
from ..runner import RunResult, _asked, _asked_text, prepare_out_dir, refuse_earlier_run
from ..io.lock import claim
from ..io.trajectory import Recorder, skin_bounds
from ..io.vtk import PVDSeries
from .simulator import AllStopped, DistributedSimulator, on_root, world
from ..scene_handles import apply_handle_tables
from ..skin import default_skin

__all__ = ["run_scene_distributed", "cli_run", "StoppedTogether"]

RERUN = "under mpiexec no checkpoint is kept: run it again with --overwrite to start afresh"


class StoppedTogether(KeyboardInterrupt):
    """Raised on every rank after a Ctrl-C or SIGTERM on rank 0 during the stepping: the ranks
    agreed at the next frame to stop, rank 0 saved the frames so far; nothing is left waiting
    (``cli_run`` ends each rank with exit 130, no ``MPI_Abort``)."""

    def __init__(self, message: str, path=None):
        super().__init__(message)
        self.message, self.path = message, path


class _StopAtFrame:
    """On rank 0, while the ranks step: SIGINT and SIGTERM set a flag that every rank reads at
    the next frame (:meth:`agreed`); a second signal interrupts at once (the abort path).
    Elsewhere (and off the main thread) it changes nothing."""

    def __init__(self, comm):
        self.comm, self.asked, self.saved = comm, 0, {}

    def __enter__(self):
        import signal
        import threading

        if self.comm.Get_rank() == 0 and threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self.saved[sig] = signal.signal(sig, self._ask)
        return self

    def _ask(self, signum, frame):
        self.asked += 1
        if self.asked > 1:
            raise KeyboardInterrupt

    def agreed(self) -> bool:
        from mpi4py import MPI

        return bool(self.comm.allreduce(int(self.asked > 0), op=MPI.MAX))

    def __exit__(self, *exc):
        import signal

        for sig, handler in self.saved.items():
            signal.signal(sig, handler)
        return False


def run_scene_distributed(scene, out_dir, *, comm=None, progress: bool = True,
                          vtu: bool | None = None, steps: int | None = None,
                          partition: str = "morton", skin="auto", overwrite: bool = False,
                          notify=None) -> RunResult | None:
    """:func:`jellysim.runner.run_scene` over the ranks of ``comm``; a collective call.
    Returns the :class:`~jellysim.runner.RunResult` on rank 0, ``None`` elsewhere.  Rank 0,
    which writes, holds the output folder's lock (:mod:`jellysim.io.lock`) while it runs;
    an earlier run there is refused unless ``overwrite`` (then its files go first), and
    ``notify`` (rank 0) hears the build's warnings before the stepping, as in a serial run."""
    comm = world() if comm is None else comm
    out_dir = Path(out_dir)
    created = not out_dir.exists()  # (rank 0's view: it alone writes)

    def claim_folder():
        out_dir.mkdir(parents=True, exist_ok=True)
        lock = claim(out_dir)
        try:
            refuse_earlier_run(out_dir, overwrite, "--overwrite")
        except JellysimError:
            lock.unlink(missing_ok=True)
            raise
        return lock

    lock = on_root(comm, claim_folder, share=False)  # a refusal is raised on every rank
    try:
        return _run_distributed(scene, out_dir, comm, progress=progress, vtu=vtu, steps=steps,
                                partition=partition, skin=skin, notify=notify,
                                overwrite=overwrite)
    finally:
        if lock is not None:
            lock.unlink(missing_ok=True)
            if created and not any(out_dir.iterdir()):  # refused before anything was written
                out_dir.rmdir()


def _run_distributed(scene, out_dir: Path, comm, *, progress, vtu, steps, partition, skin,
                     notify=None, overwrite=False):
    """:func:`run_scene_distributed` once rank 0 holds the folder."""
    rank, size = comm.Get_rank(), comm.Get_size()

    def build():
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                model = scene.build_model()
            except JellysimError as exc:  # what the build said may explain it (mesh units)
                exc.run_warnings = [str(w.message) for w in caught]
                raise
        return model, [str(w.message) for w in caught]

    # rank 0 alone holds the global model: it sends every rank its part (DistributedSimulator)
    model = on_root(comm, build, share=False)
    model, messages = (model if rank == 0 else (None, None))
    kw = on_root(comm, lambda: {k: v for k, v in scene.simulator_kwargs(model).items()
                                if k != "state"})
    state = scene.simulator_kwargs(model).get("state") if rank == 0 else None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            sim = DistributedSimulator(model, comm=comm, partition=partition, state=state,
                                       **kw)
        except SceneError as exc:  # name the scene file, as a serial run does
            msg = str(exc)
            raise SceneError(msg if msg.startswith(f"{scene.name}:") else
                             f"{scene.name}: {msg}") from None
        prepare(scene, sim)
    if rank == 0:
        messages += [str(w.message) for w in caught]
        if sim.oversubscribed:
            messages.append(sim.oversubscribed)
        if sim.replicated:
            messages.append(f"every rank runs the whole body ({sim.replicated}): the run "
                            "is correct but not faster than one process")
    for m in dict.fromkeys(messages) if rank == 0 and notify is not None else ():
        notify(m)
    total = scene.steps if steps is None else int(steps)
    every = scene.frame_every
    recorder = series = skin_series = None
    if rank == 0:
        out_dir.mkdir(parents=True, exist_ok=True)
        if overwrite:  # the new run starts: the earlier one's files go
            prepare_out_dir(out_dir, overwrite=True, held=True)
        if isinstance(skin, str) and skin == "auto":
            try:
                skin = default_skin(scene, model.body)
            except BuildError as exc:
                messages.append(f"no skin: {exc}")
                skin = None
        recorder = Recorder(model, scene_text=_asked_text(scene, total),
                            params=_asked(scene.params, total), skin=skin)
        write_vtu = scene.params["output"]["vtu"] if vtu is None else vtu
        series = PVDSeries(out_dir) if write_vtu else None
        skin_series = PVDSeries(out_dir, "skin") if write_vtu and skin is not None else None
        bounds = skin_bounds(scene.params)  # the ground and obstacles the skin is kept out of

    def emit():
        state = sim.gather(0)
        if rank != 0:
            return
        recorder.record(state)
        if series is not None:
            physical = model.fem is not None  # its tets alone, as serially
            series.add(state.t, state.x, model.spring_ij[:0] if physical else model.spring_ij,
                       velocities=state.v, rest=model.point_x0,
                       triangles=None if physical else model.body.triangles,
                       tets=model.fem.tets if physical else model.body.tets)
        if skin_series is not None:
            skin_series.add_surface(state.t, skin.deform(state.x, **bounds), skin.faces)

    emit()
    bar = None
    if progress and rank == 0:
        from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn,
                                   TimeRemainingColumn)

        bar = Progress(TextColumn(f"[bold]simulating on {size} ranks"), BarColumn(),
                       MofNCompleteColumn(), TextColumn("steps"), TimeRemainingColumn(),
                       transient=False)
        bar.start()
        task = bar.add_task("run", total=total)
    stepped = 0.0
    during = warnings.catch_warnings(record=True)  # run-time warnings: into the result
    caught = during.__enter__()
    warnings.simplefilter("always")
    stop = _StopAtFrame(comm)
    try:
        done = 0
        with stop:
            while done < total:
                n = min(every, total - done)
                t0 = time.perf_counter()
                try:
                    sim.advance(n)
                finally:
                    stepped += time.perf_counter() - t0
                done += n
                emit()
                if bar is not None:
                    bar.update(task, completed=done)
                if done < total and stop.agreed():  # every rank stops at this frame
                    path = None
                    if rank == 0:
                        path = _save(recorder, out_dir / "trajectory.npz", status=(
                            f"interrupted at step {done} of {total} ({RERUN})"),
                            overwrite=True, held=True)
                    raise StoppedTogether(f"interrupted at step {done} of {total}", path)
    except SimulationError as exc:
        emit()
        if rank == 0:
            _save(recorder, out_dir / "trajectory.npz", status=f"failed: {exc}", overwrite=True,
                          held=True)
        raise
    except StoppedTogether:
        raise
    except KeyboardInterrupt:  # a second Ctrl-C: rank 0 keeps the frames so far, aborts
        if rank == 0:
            _save(recorder, out_dir / "trajectory.npz", status=(
                f"interrupted at step {done} of {total} ({RERUN})"), overwrite=True,
                held=True)
        raise
    finally:
        during.__exit__(None, None, None)
        if bar is not None:
            bar.stop()
    if rank != 0:
        return None
    messages += [str(w.message) for w in caught]
    path = _save(recorder, out_dir / "trajectory.npz", overwrite=True, held=True)
    return RunResult(out_dir, path, series.pvd_path if series else None,
                     len(recorder.times), total, stepped, messages,
                     simulated=total * float(sim.dt))


def _save(recorder, path, **kw):
    """Rank 0 writes the frames, which only its memory holds, with Ctrl-C and SIGTERM held
    off until the file is complete (HPC trial: a second Ctrl-C during a save of 700 frames,
    1.5 s, ended the job with no trajectory.npz); a signal that lands meanwhile is dropped:
    the run ends right after anyway, stopped or finished."""
    from .._interrupts import held

    with held(act=False):
        return recorder.save(path, **kw)


def prepare(scene, sim) -> None:
    """:meth:`Scene.prepare` for a :class:`~.simulator.DistributedSimulator`: the initial
    velocity on every local point, and the ``[[handle]]`` tables, whose points rank 0 selects
    from the global start positions; every rank then makes the same handle calls."""
    import types

    import numpy as np

    if scene.params["body"].get("settle"):
        raise SceneError(f"{scene.name}: [body] settle runs serially: settle the body in a "
                         "serial run (jellysim run without mpiexec) or remove it")
    sim.state.v[:] = np.asarray(scene.params["body"]["velocity"], dtype=np.float64)
    if not scene.params.get("handle"):
        return

    def select():
        calls = []

        def record(name):
            return lambda *args, **kw: calls.append((name, args, kw))

        view = types.SimpleNamespace(state=types.SimpleNamespace(x=sim.global_start.x),
                                     pin=record("pin"), apply_force=record("apply_force"),
                                     set_gravity_scale=record("set_gravity_scale"))
        try:
            apply_handle_tables(view, scene.params["handle"])
        except SceneError as exc:
            raise SceneError(f"{scene.name}: {exc}") from None
        return calls

    for name, args, kw in on_root(sim.comm, select):
        getattr(sim, name)(*args, **kw)


def _leave_signals_to_root() -> None:
    """On a rank other than 0: ignore SIGINT and SIGTERM.  A terminal's Ctrl-C reaches every
    rank; rank 0 acts on it and tells the others (at the next frame, or through
    :func:`~.simulator.on_root` while it builds), so every rank ends together; a second one
    makes rank 0 save the frames so far and abort the job (which ends this rank too)."""
    import signal
    import threading

    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, signal.SIG_IGN)


def cli_run(scene_file, out_dir, *, steps=None, no_vtu=False, quiet=False,
            partition="morton", video=None, usd=None, glb=None, overwrite=False,
            say=None, load=None) -> None:
    """The body of ``jellysim run`` under ``mpiexec`` (``load``: makes the scene with the
    command line's overrides; default: the file as written): errors agreed by all ranks (bad scene,
    blow-up) are printed once by rank 0; any other error is printed as ``rank R: ...`` by the
    rank that hit it, which then aborts the whole job."""
    import click

    from ..scene import Scene

    try:
        comm = world()
    except JellysimError as exc:
        click.secho(f"error: {exc}", fg="red", err=True)
        sys.exit(2)
    rank = comm.Get_rank()
    if rank != 0:  # Ctrl-C (sent to every rank) and SIGTERM are rank 0's to act on: it saves
        _leave_signals_to_root()  # the frames and ends the job; a rank aborting first lost them

    def fail(message, code=2):
        if rank == 0:
            click.secho(f"error: {message}", fg="red", err=True)
        sys.exit(code)

    try:
        scene = Scene.load(scene_file) if load is None else load()
        out = Path(out_dir) if out_dir else Path("out") / Path(scene_file).stem
        result = run_scene_distributed(scene, out, comm=comm, progress=not quiet,
                                       vtu=False if no_vtu else None, steps=steps,
                                       partition=partition, overwrite=overwrite, notify=say)
    except JellysimError as exc:
        for w in getattr(exc, "run_warnings", ()) if rank == 0 and say is not None else ():
            say(w)
        fail(str(exc))
    except StoppedTogether as stopped:  # every rank stopped at one frame: none is waiting
        if rank == 0:
            click.secho(f"{stopped.message} on {comm.Get_size()} ranks; its frames so far "
                        f"are in {stopped.path} (status 'interrupted'); {RERUN}",
                        fg="yellow", err=True)
        sys.exit(130)
    except AllStopped:  # while rank 0 built the body: every rank told, none waiting
        if rank == 0:
            click.secho("interrupted: the run stopped before its first frame; nothing was "
                        "written", fg="yellow", err=True)
        sys.exit(130)
    except KeyboardInterrupt:  # Ctrl-C (every rank) or SIGTERM: end every rank, not a hang
        if rank == 0:
            where = locals().get("out")
            kept = where is not None and (where / "trajectory.npz").exists()
            click.secho("interrupted: the run stopped" + (
                f"; its frames so far are in {where / 'trajectory.npz'} (status "
                f"'interrupted'); {RERUN}" if kept else
                " before its first frame; nothing was written"), fg="yellow", err=True)
            sys.stderr.flush()
            time.sleep(0.5)  # (the launcher forwards the line before Abort ends the job)
        comm.Abort(130)
        sys.exit(130)  # (should Abort return)
    except Exception as exc:  # one rank only: say which, and do not leave the others waiting
        sys.stderr.write(f"error: rank {rank} of {comm.Get_size()}: {type(exc).__name__}: "
                         f"{exc}\n{traceback.format_exc()}")
        sys.stderr.flush()
        comm.Abort(3)
        sys.exit(3)
    if rank != 0:
        return
    for w in result.warnings:
        (say or (lambda m: click.secho(f"warning: {m}", fg="yellow", err=True)))(w)
    rate = result.steps / result.seconds if result.seconds > 0 else float("inf")
    click.echo(f"{result.steps} steps, {result.frames} frames in {result.seconds:.3g} s "
               f"({rate:,.0f} steps/s, {result.simulated / max(result.seconds, 1e-300):.2g}x "
               f"real time) on {comm.Get_size()} ranks")
    from ..cli_visual import echo_run_outputs

    echo_run_outputs(result, fail, video=video, usd=usd, glb=glb, quiet=quiet)
