"""Run a scene: build, simulate frame by frame, record, write outputs.

Outputs in ``out_dir``: ``trajectory.npz`` (see :mod:`jellysim.io.trajectory`) and, unless
disabled, the ParaView series ``body.pvd`` + ``body_NNNNN.vtu`` (and ``skin.pvd`` +
``skin_NNNNN.vtu`` when the body carries a skin, see :mod:`jellysim.skin`).  If the run goes
unstable, the frames written so far are kept (the trajectory is saved with
``status = "failed: ..."``) and the :class:`~jellysim.errors.SimulationError` is re-raised.
"""
from __future__ import annotations

import fnmatch
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from .errors import JellysimError, SimulationError
from .io.trajectory import Recorder
from .io.vtk import PVDSeries

__all__ = ["RUN_FILES", "RunResult", "prepare_out_dir", "run_scene"]

RUN_FILES = ("trajectory.npz", "body.pvd", "body_*.vtu", "skin.pvd", "skin_*.vtu",
             ".trajectory.npz.*", ".body*", ".skin*")
"""Names (glob patterns) of the files a run writes into its folder: what ``--overwrite``
removes before a new run (nothing else in the folder is touched)."""


def prepare_out_dir(out_dir, *, overwrite: bool = False, owned=RUN_FILES,
                    option: str = "--out") -> Path:
    """Make ``out_dir`` ready for a run: create it; if it already holds files, refuse
    (:class:`~jellysim.errors.JellysimError`) unless ``overwrite``, and then delete the files
    an earlier run wrote there (names matching ``owned``), so no stale frame survives.
    Files that are not a run's are kept.  Returns the folder."""
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise JellysimError(f"{option} {out_dir}: exists and is not a folder")
    present = sorted(out_dir.iterdir()) if out_dir.is_dir() else []
    if present and not overwrite:
        names = ", ".join(p.name for p in present[:3]) + (", ..." if len(present) > 3 else "")
        raise JellysimError(f"{option} {out_dir}: the folder is not empty ({len(present)} "
                            f"entries: {names}); pass --overwrite to replace the run there, "
                            f"or choose another {option}")
    for p in present:
        if p.is_file() and any(fnmatch.fnmatchcase(p.name, pat) for pat in owned):
            p.unlink()
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


def run_scene(scene, out_dir, *, progress: bool = True, vtu: bool | None = None,
              steps: int | None = None, skin="auto", body=None) -> RunResult:
    """Simulate ``scene`` (a :class:`~jellysim.scene.Scene`) and write its outputs.

    ``skin``: a :class:`~jellysim.skin.Skin` to carry, ``None`` for none, or ``"auto"``
    (:func:`jellysim.skin.default_skin`: the box surface for box scenes).
    ``body``: a :class:`~jellysim.body.Body` to simulate instead of the scene's own."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = scene.build_model(body)
        sim = scene.simulator(model)
    messages = [str(w.message) for w in caught]
    if isinstance(skin, str) and skin == "auto":
        from .errors import BuildError
        from .skin import default_skin

        try:
            skin = default_skin(scene, model.body)
        except BuildError as exc:
            messages.append(f"no skin: {exc}")
            skin = None
    total = scene.steps if steps is None else int(steps)
    every = scene.frame_every
    recorder = Recorder(model, scene_text=scene.text, params=scene.params, skin=skin)
    write_vtu = scene.params["output"]["vtu"] if vtu is None else vtu
    series = PVDSeries(out_dir) if write_vtu else None
    skin_series = PVDSeries(out_dir, "skin") if write_vtu and skin is not None else None
    body = model.body

    def emit():
        recorder.record(sim.state)
        if series is not None:
            series.add(sim.state.t, sim.state.x, model.spring_ij, velocities=sim.state.v,
                       triangles=body.triangles)
        if skin_series is not None:
            skin_series.add_surface(sim.state.t, skin.deform(sim.state.x), skin.faces)

    emit()
    stepped = 0.0
    bar = None
    if progress:
        from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn,
                                   TimeRemainingColumn)

        bar = Progress(TextColumn("[bold]simulating"), BarColumn(), MofNCompleteColumn(),
                       TextColumn("steps"), TimeRemainingColumn(), transient=False)
        bar.start()
        task = bar.add_task("run", total=total)
    try:
        done = 0
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
    except SimulationError as exc:
        emit()
        recorder.save(out_dir / "trajectory.npz", status=f"failed: {exc}")
        raise
    finally:
        if bar is not None:
            bar.stop()
    path = recorder.save(out_dir / "trajectory.npz")
    return RunResult(out_dir, path, series.pvd_path if series else None,
                     len(recorder.times), total, stepped, messages)
