"""Checkpoints: everything a run needs to continue bit-identically, in ``checkpoint.npz``.

Stored arrays:

======================  =========  ================================================
``state.x``             (n, 3) f8  positions [m]
``state.v``             (n, 3) f8  velocities [m/s]
``state.a``             (n, 3) f8  accelerations [m/s^2]
``state.t``             () f8      simulated time [s]
``state.step``          () i8      steps taken
``frames``              () i8      frames in the trajectory stream at this point
``sim.<name>``          any        :meth:`Simulator.internal_state` (solver history, contact
                                   state, CG warm start and counters)
``frame_every``         () i8      steps between the run's saved frames
``total_steps``         () i8      steps the run was asked for
``scene_steps``         () i8      its scene's ``[integrator] steps`` (a changed one asks for
                                   a longer or shorter run)
``vtu``                 () bool    whether the run writes its ParaView series (a resume or an
                                   extension keeps that choice)
``scene_params``        str        those parameters as JSON (a refusal names what differs;
                                   ``jellysim run --resume DIR`` rebuilds the scene from them)
``scene_path``          str        the scene file (absolute), against which its relative paths
                                   resolve; ``<scene>`` for a scene made in Python
``scene_sha256``        str        hash of the scene's resolved parameters, all but the run's
                                   length (``[integrator] steps``), so a run can be extended
``model_sha256``        str        hash of the built body (rest positions, masses, springs)
``version``             str        jellysim version that wrote it
======================  =========  ================================================

A checkpoint is taken right after a frame is flushed, so the stream holds at least ``frames``
frames.  It is written through ``checkpoint.npz.partial`` and an atomic rename.  No random
stream is consumed during a run (the seeded ones are used while building the body, which is
rebuilt identically and checked by ``model_sha256``).
"""
from __future__ import annotations

import hashlib
import io
import json
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import CheckpointError
from .. import __version__
from .stream import write_replace

__all__ = ["CHECKPOINT", "FINAL_CHECKPOINT", "Checkpoint", "model_hash", "scene_hash",
           "write_checkpoint", "read_checkpoint"]

CHECKPOINT = "checkpoint.npz"
FINAL_CHECKPOINT = "checkpoint.final.npz"
"""The state a completed run ended in: ``--resume --steps M`` extends the run from it."""


def _version() -> str:
    return __version__


def _hashed_params(scene, threads: bool = False) -> str:
    """The resolved parameters without the run's length and (unless ``threads``) the thread
    count, as canonical JSON."""
    params = {k: dict(v) if isinstance(v, dict) else v for k, v in scene.params.items()}
    if isinstance(params.get("integrator"), dict):
        params["integrator"].pop("steps", None)
        if not threads:
            params["integrator"].pop("threads", None)
    return json.dumps(params, sort_keys=True, default=str)


def scene_hash(scene, threads: bool = False) -> str:
    """Hash of the resolved parameters (the text's and every ``--set``), without the run's
    length (a run continued for more steps is the same scene) and the thread count (the
    results are bitwise the same for any: a run stopped on 2 threads resumes on 1; hashes
    written before session 13 held it: ``threads=True``)."""
    return hashlib.sha256(_hashed_params(scene, threads).encode("utf-8")).hexdigest()


def _differences(written: str, scene) -> str:
    """`` (section.key: <checkpoint's> here, <scene's> now; ...)`` for up to three keys."""
    try:
        old, new = json.loads(written), json.loads(_hashed_params(scene))
    except (ValueError, TypeError):
        return ""
    diff = []
    for section in sorted(set(old) | set(new)):
        a, b = old.get(section), new.get(section)
        if isinstance(a, dict) and isinstance(b, dict):
            diff += [f"{section}.{k}: {a.get(k)!r} then, {b.get(k)!r} now"
                     for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)]
        elif a != b:
            diff.append(f"{section}: differs")
    return (" (" + "; ".join(diff[:3]) + ("; ..." if len(diff) > 3 else "") + ")") if diff else ""


def _legacy_hash(scene) -> str:
    """The scene hash of checkpoints written before session 10 (text and every parameter):
    their runs still resume (not extend: their scene_steps is unknown)."""
    h = hashlib.sha256(scene.text.encode("utf-8"))
    h.update(json.dumps(scene.params, sort_keys=True, default=str).encode("utf-8"))
    return h.hexdigest()


def model_hash(model) -> str:
    h = hashlib.sha256()
    for a in (model.point_x0, model.point_mass, model.spring_ij,
              model.spring_rest_length, model.spring_stiffness, model.gravity):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


@dataclass
class Checkpoint:
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    t: float
    step: int
    frames: int
    internal: dict
    scene_sha256: str
    model_sha256: str
    version: str
    total_steps: int | None = None
    """The run's step count (its scene's, or ``--steps``), so a resume finishes that run."""
    scene_steps: int | None = None
    """The scene's own ``[integrator] steps`` when it was written."""
    frame_every: int | None = None
    """Steps between the run's saved frames, so a longer continuation keeps their schedule."""
    vtu: bool | None = None
    """Whether the run writes its ParaView series."""
    scene_params: str = ""
    """The parameters it was written for (JSON, without the run's length)."""
    scene_path: str = ""
    """The scene file it was written for (absolute; empty in files of earlier versions)."""


def write_checkpoint(path, sim, *, frames: int, scene, model, total: int | None = None,
                     every: int | None = None, vtu: bool | None = None) -> Path:
    s = sim.state
    arrays = {"state.x": s.x, "state.v": s.v, "state.a": s.a,
              "state.t": np.array(float(s.t)), "state.step": np.array(int(s.step)),
              "frames": np.array(int(frames)),
              "scene_sha256": np.array(scene_hash(scene)),
              "scene_params": np.array(_hashed_params(scene)),
              "model_sha256": np.array(model_hash(model)),
              "version": np.array(_version()),
              "scene_path": np.array(_scene_path(scene))}
    if total is not None:
        arrays["total_steps"] = np.array(int(total))
    if every is not None:
        arrays["frame_every"] = np.array(int(every))
    if vtu is not None:
        arrays["vtu"] = np.array(bool(vtu))
    if getattr(scene, "params", None) is not None:
        arrays["scene_steps"] = np.array(int(scene.params["integrator"]["steps"]))
    for k, v in sim.internal_state().items():
        arrays[f"sim.{k}"] = v
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    write_replace(path, buf.getvalue())
    return Path(path)


def _scene_path(scene) -> str:
    name = str(getattr(scene, "name", "<scene>"))
    return str(Path(name).resolve()) if Path(name).is_file() else name


def run_status(out_dir) -> str:
    """The ``status`` the run's saved trajectory records ("" when there is none to read)."""
    try:
        from .trajectory import load_trajectory

        return str(load_trajectory(Path(out_dir), mmap=True).status or "")
    except Exception:  # noqa: BLE001  (no trajectory, or a damaged one: nothing known)
        return ""


def mpiexec_interruption(out_dir, status: str) -> str | None:
    """The refusal to resume a run interrupted under mpiexec (which keeps no checkpoint),
    or ``None`` when ``status`` is not such a run's."""
    if not (status.startswith("interrupted") and "mpiexec" in status):
        return None
    return (f"{out_dir}: cannot resume: the run was interrupted under mpiexec at step "
            f"{status.split()[3]}, and mpiexec runs keep no checkpoint: run it again with "
            "--overwrite to start afresh")


def scene_of_run(out_dir, *, overrides=()):
    """The :class:`~jellysim.scene.Scene` a run in ``out_dir`` was made with, rebuilt from its
    checkpoint (``jellysim run --resume DIR`` without the scene file): its resolved parameters,
    ``overrides`` (``"section.key=value"``) applied over them, named after the scene file
    so that relative paths resolve as they did.  Raises :class:`CheckpointError` when the
    folder holds no checkpoint, or one of a version that did not record the parameters."""
    from ..scene import Scene
    from ..scene_spec import apply_override

    out_dir = Path(out_dir)
    if not out_dir.is_dir():
        raise CheckpointError(f"--resume {out_dir}: no such folder; give the output folder of "
                              "the run to continue (the one its interrupted run printed)")
    path = next((out_dir / n for n in (CHECKPOINT, FINAL_CHECKPOINT)
                 if (out_dir / n).is_file()), out_dir / CHECKPOINT)
    if not path.is_file():  # an mpiexec run keeps no checkpoint: say so, not "none found"
        status = run_status(out_dir)
        interrupted = mpiexec_interruption(out_dir, status)
        if interrupted:
            raise CheckpointError(interrupted)
        if status == "complete":
            raise CheckpointError(
                f"--resume {out_dir}: the run has finished and kept no checkpoint to continue "
                "from (mpiexec runs keep none; a serial run that finished keeps "
                "checkpoint.final.npz): run it again with the scene file and --overwrite")
    ck = read_checkpoint(path)
    if not ck.scene_params or ck.scene_steps is None:
        raise CheckpointError(f"{path}: written by an earlier jellysim that did not record the "
                              "scene: give the scene file too (jellysim run SCENE --resume "
                              f"{out_dir})")
    raw = json.loads(ck.scene_params)
    raw["integrator"]["steps"] = ck.scene_steps
    name = ck.scene_path or "<scene>"
    for item in overrides:
        apply_override(raw, item, name)
    scene = Scene.from_dict(raw, name=name)
    scene.overrides = tuple(overrides)
    scene.from_run = out_dir  # (what a stop prints to continue: jellysim run --resume DIR)
    try:
        from .trajectory import load_trajectory

        text = load_trajectory(out_dir, mmap=True).scene_toml  # (the file's own text)
        scene.text = text.split("\n# run for ")[0].rstrip("\n") + "\n"
    except Exception:  # noqa: BLE001  (the rebuilt text stands in)
        pass
    return scene


def read_checkpoint(path, *, scene=None, model=None) -> Checkpoint:
    """Read and validate a checkpoint: raises :class:`CheckpointError` when it is missing or
    damaged, or was written by another jellysim version, for another scene or body."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"{path}: no checkpoint to resume from (a run leaves one when "
                              "it is interrupted, or every [output] checkpoint_every steps)")
    try:
        with np.load(path, allow_pickle=False) as z:
            d = {k: z[k] for k in z.files}
        ck = Checkpoint(
            x=d["state.x"], v=d["state.v"], a=d["state.a"], t=float(d["state.t"]),
            step=int(d["state.step"]), frames=int(d["frames"]),
            internal={k[4:]: v for k, v in d.items() if k.startswith("sim.")},
            scene_sha256=str(d["scene_sha256"]), model_sha256=str(d["model_sha256"]),
            version=str(d["version"]),
            total_steps=int(d["total_steps"]) if "total_steps" in d else None,
            frame_every=int(d["frame_every"]) if "frame_every" in d else None,
            scene_steps=int(d["scene_steps"]) if "scene_steps" in d else None,
            vtu=bool(d["vtu"]) if "vtu" in d else None,
            scene_params=str(d["scene_params"]) if "scene_params" in d else "",
            scene_path=str(d["scene_path"]) if "scene_path" in d else "")
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
        raise CheckpointError(f"{path}: damaged checkpoint ({exc}: cut short or overwritten?); "
                              "start the run afresh: without --resume, with --overwrite") from None
    if ck.version != _version():
        raise CheckpointError(f"{path}: written by jellysim {ck.version}, this is "
                              f"{_version()}; resume with that version or start afresh")
    if scene is not None and ck.scene_sha256 not in (scene_hash(scene), _legacy_hash(scene),
                                                     scene_hash(scene, threads=True)):
        raise CheckpointError(f"{path}: written for another scene (its parameters differ from "
                              f"{scene.name}'s, the run's length aside"
                              f"{_differences(ck.scene_params, scene)}); resume with the same "
                              "scene file, --set items and --backend / --device / --precision "
                              "(the command the interrupted run printed), or start afresh "
                              "without --resume")
    if model is not None and ck.model_sha256 != model_hash(model):
        raise CheckpointError(f"{path}: the body built from {getattr(scene, 'name', 'the scene')}"
                              " differs from the checkpoint's (a mesh or body file changed?); "
                              "start afresh without --resume")
    if model is not None and ck.x.shape != (model.point_count, 3):
        raise CheckpointError(f"{path}: holds {ck.x.shape[0]} points, the body has "
                              f"{model.point_count}")
    return ck
