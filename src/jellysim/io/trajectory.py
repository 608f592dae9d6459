"""Trajectories: positions per frame plus everything needed to interpret them, in one ``.npz``.

A run streams its frames to ``trajectory.stream/`` while it goes (:mod:`jellysim.io.stream`)
and writes the ``.npz`` at the end; :func:`load_trajectory` reads either.

Arrays stored (SI units):

=================  ==============  =============================================
``positions``      (F, n, 3) f8    positions per frame [m]
``velocities``     (F, n, 3) f8    velocities per frame [m/s]
``times``          (F,) f8         simulated time of each frame [s]
``steps``          (F,) i8         time-step index of each frame
``rest_positions`` (n, 3) f8       rest positions [m]
``masses``         (n,) f8         point masses [kg]
``springs``        (k, 2) i4       spring end points
``rest_length``    (k,) f8         spring rest lengths [m]
``stiffness``      (k,) f8         spring stiffness [N/m]
``gravity``        (3,) f8         [m/s^2]
``triangles``      (f, 3) i8       surface triangles (may be empty)
``tets``           (t, 4) i8       tetrahedra (may be empty)
``scene_toml``     str             the scene file's text
``params_json``    str             every resolved parameter, as JSON (a scene run: the scene's;
                                   a Python :class:`Recorder` of a Simulator: ``simulator``)
``status``         str             ``"complete"``, ``"failed: <message>"`` (or, read from a
                                   stream: ``"interrupted at step N ..."``, ``"incomplete: ..."``)
=================  ==============  =============================================

Optional skin (:mod:`jellysim.skin`; absent in older files, which load with ``skin = None``):

======================  ==========  ===========================================
``skin_rest_vertices``  (m, 3) f8   skin vertices at rest [m]
``skin_faces``          (f, 3) i8   skin triangles
``skin_point_index``    (m, 4) i8   the four points each skin vertex follows
``skin_weights``        (m, 4) f8   their weights (rows sum to 1)
``skin_uv``             (f, 3, 2) f8  texture coordinates of each face corner (when the
                                    mesh file had UVs)
======================  ==========  ===========================================
"""
from __future__ import annotations

import functools

import json
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .atomic import atomic_path
from ..errors import JellysimError
from .stream import STREAM_DIR, read_stream
from ..skin import Skin
from .npzcheck import check_npz

__all__ = ["Recorder", "Trajectory", "load_trajectory", "resolve_trajectory", "trajectory_meta"]


class Recorder:
    """Collects frames in memory and writes them as one ``.npz`` (for short runs from Python;
    ``jellysim run`` streams its frames to disk instead, :mod:`jellysim.io.stream`)."""

    def __init__(self, model, *, scene_text: str = "", params: dict | None = None,
                 skin="auto"):
        """``skin``: a :class:`~jellysim.skin.Skin` to carry, ``None`` for none, or
        ``"auto"`` (default): the surface the body was built from (``Body.from_mesh``, a
        body file), bound to its tets, so renders and exports show the smooth shape; for a
        body of points and springs alone, the outer faces of the cells its springs hold
        (:func:`jellysim.skin.outer_skin`)."""
        self.model = model
        if isinstance(skin, str) and skin == "auto":
            from ..errors import BuildError
            from ..skin import default_skin

            try:
                skin = default_skin(None, model.body)
            except BuildError:  # a surface that does not bind: drawn by its tets instead
                skin = None
        self.skin = skin
        self.scene_text = scene_text
        self.params = params or {}
        self.positions: list[np.ndarray] = []
        self.velocities: list[np.ndarray] = []
        self.times: list[float] = []
        self.steps: list[int] = []

    def record(self, state) -> None:
        """Keep ``state``'s positions, velocities, time and step (a state of this model).
        ``state`` may be the :class:`~jellysim.simulator.Simulator` itself: its ground is then
        kept too, so that ``jellysim render`` draws the floor where it was (a recording of
        states alone says nothing of a ground, and none is drawn)."""
        ground = getattr(state, "ground", None)
        if ground is not None and hasattr(state, "state"):
            if "simulator" not in self.params and not self.scene_text:  # how a Python run
                try:  # ran (session 14's trial: its recording kept only E, nu and the ground)
                    self.params["simulator"] = _simulator_params(state)
                except AttributeError:  # (a simulator of another kind: its scene says it)
                    pass
            state = state.state
            if "ground" not in self.params:
                self.params["ground"] = {"enabled": bool(ground.enabled),
                                         "height": float(ground.height),
                                         "model": getattr(ground.model, "value", "paper")}
        n = self.model.point_count
        if np.shape(state.x) != (n, 3) or np.shape(state.v) != (n, 3):
            raise ValueError(f"Recorder.record: the state has {np.shape(state.x)} positions; "
                             f"this recorder's model has {n} points (record the state of the "
                             "simulator built from the same model)")
        self.positions.append(state.x.copy())
        self.velocities.append(state.v.copy())
        self.times.append(float(state.t))
        self.steps.append(int(state.step))

    def save(self, path, *, status: str = "complete", overwrite: bool = False,
             held: bool = False) -> Path:
        """Write the frames to ``path`` (``.npz``; atomically).  A file there from an earlier
        save is replaced; any other file there (not a recording: it would be lost) is refused
        unless ``overwrite``, and so is one in the folder of a ``jellysim run`` (its checkpoint, frame
        stream or lock beside it, which would no longer match) is refused unless
        ``overwrite``; a folder a live run is writing, always (``held``: the caller is that
        run, saving its own trajectory)."""
        from ..errors import OutputError

        n = self.model.point_count
        if not self.times:
            raise OutputError(f"{path}: no frame recorded: call record(sim.state) at least "
                              "once before save")
        path = Path(path)
        if path.suffix.lower() != ".npz":
            raise OutputError(f"{path}: a recording is saved as .npz (what load_trajectory and "
                              f"jellysim render/export read): name it "
                              f"{path.with_suffix('.npz').name}")
        if path.is_dir():
            raise OutputError(f"{path}: is a folder; give a file name ending in .npz")
        if path.exists() and not overwrite and not _is_recording(path):
            raise OutputError(f"{path}: exists and is not a jellysim recording: it would be "
                              "lost; save elsewhere, or pass overwrite=True to replace it")
        from .lock import refuse_if_held

        if path.parent.is_dir() and not held:  # a live run writes there: never
            refuse_if_held(path.parent)
        if path.exists() and not overwrite:
            beside = [name for name in ("checkpoint.npz", "checkpoint.final.npz",
                                        "trajectory.stream", ".jellysim.lock")
                      if (path.parent / name).exists()]
            if beside:
                raise OutputError(f"{path}: is in a jellysim run's folder ({beside[0]} beside "
                                  "it would no longer match): save elsewhere, or pass "
                                  "overwrite=True to replace it")
        meta = trajectory_meta(self.model, scene_text=self.scene_text, params=self.params,
                               skin=self.skin)
        with atomic_path(path) as tmp:
            with open(tmp, "wb") as fh:
                np.savez_compressed(
                    fh,
                    positions=np.asarray(self.positions, dtype=np.float64).reshape(-1, n, 3),
                    velocities=np.asarray(self.velocities, dtype=np.float64).reshape(-1, n, 3),
                    times=np.asarray(self.times, dtype=np.float64),
                    steps=np.asarray(self.steps, dtype=np.int64),
                    status=np.array(status), **meta)
        return Path(path)


def _is_recording(path: Path) -> bool:
    """Whether ``path`` is a zip holding a recording's frames (what :meth:`Recorder.save`
    writes), read from its directory only."""
    import zipfile

    try:
        with zipfile.ZipFile(path) as z:
            names = set(z.namelist())
    except (OSError, zipfile.BadZipFile):
        return False
    return {"positions.npy", "times.npy", "steps.npy"} <= names


def _simulator_params(sim) -> dict:
    """What a :class:`~jellysim.simulator.Simulator` runs with, as JSON values: dt [s],
    integrator, substeps, backend, precision, threads, the Provot, ground and implicit
    options, obstacles, the model's damping [kg/s] and gravity [m/s^2], and the FEM
    material's parameters when it has one."""
    import dataclasses
    from enum import Enum

    def plain(v):
        if isinstance(v, Enum):
            return v.value
        if dataclasses.is_dataclass(v) and not isinstance(v, type):
            return {f.name: plain(getattr(v, f.name)) for f in dataclasses.fields(v)}
        if isinstance(v, (list, tuple, np.ndarray)):
            return [plain(x) for x in v]
        if isinstance(v, np.generic):
            return v.item()
        return v if isinstance(v, (bool, int, float, str, type(None))) else repr(v)

    out = {"dt": float(sim.dt), "integrator": plain(sim.integrator),
           "substeps": int(sim.substeps), "backend": plain(getattr(sim, "backend", None)),
           "precision": str(getattr(sim, "precision", "float64")),
           "threads": int(getattr(sim, "threads", 1)),
           "provot": plain(sim.provot), "ground": plain(sim.ground),
           "implicit": plain(sim.implicit),
           "obstacles": [dict(kind=type(o).__name__, **plain(o)) for o in sim.obstacles],
           "damping": float(sim.model.damping), "gravity": plain(sim.model.gravity)}
    fem = getattr(sim.model, "fem", None)
    if fem is not None:
        out["fem"] = {k: plain(getattr(fem, k)) for k in (
            "youngs_modulus", "poisson_ratio", "damping_ratio", "damping_frequency",
            "branch_ratio", "branch_time")
            if hasattr(fem, k)}
    return json.loads(json.dumps(out, default=repr))


def trajectory_meta(model, *, scene_text: str = "", params: dict | None = None,
                    skin=None) -> dict[str, np.ndarray]:
    """The arrays of a trajectory that do not change from frame to frame (module table)."""
    m = model
    body = m.body
    empty3 = np.zeros((0, 3), dtype=np.int64)
    empty4 = np.zeros((0, 4), dtype=np.int64)
    extra = skin.arrays() if skin is not None else {}
    fem = getattr(m, "fem", None)
    if fem is not None:  # what `jellysim plot` needs for the tets' elastic energy
        params = dict(params or {}, fem={"youngs_modulus": float(fem.youngs_modulus),
                                         "poisson_ratio": float(fem.poisson_ratio)})
    triangles = body.triangles
    tets = body.tets if body.tets is not None else getattr(fem, "tets", None)
    if triangles is None and tets is not None and len(tets):
        # a body without surface triangles but with tets (a grid box, a Python-built body):
        # its tets' outer faces, outward, so render and export show its surface
        from ..geometry.tetra import boundary_faces, orient_tets

        triangles = boundary_faces(orient_tets(m.point_x0, tets), m.point_count)
    return dict(rest_positions=m.point_x0, masses=m.point_mass,
                springs=m.spring_ij, rest_length=m.spring_rest_length,
                stiffness=m.spring_stiffness, gravity=m.gravity,
                triangles=triangles if triangles is not None else empty3,
                tets=tets if tets is not None else empty4,
                scene_toml=np.array(scene_text),
                params_json=np.array(json.dumps(params or {}, sort_keys=True)), **extra)


@dataclass
class Trajectory:
    """A loaded trajectory (the module table has every array).  Per frame (F frames, n
    points): ``positions`` [m] (F, n, 3), ``velocities`` [m/s] (F, n, 3), ``times`` [s] (F,),
    ``steps`` (F,); the body: ``rest_positions`` [m] (n, 3), ``masses`` [kg] (n,),
    ``springs`` (k, 2), ``rest_length`` [m], ``stiffness`` [N/m], ``triangles`` (surface),
    ``tets``; the run: ``scene_toml``, ``params``, ``status``; ``skin`` and the method
    :meth:`skin_positions` (frame) for the deformed skin [m]."""

    positions: np.ndarray
    velocities: np.ndarray
    times: np.ndarray
    steps: np.ndarray
    rest_positions: np.ndarray
    masses: np.ndarray
    springs: np.ndarray
    rest_length: np.ndarray
    stiffness: np.ndarray
    gravity: np.ndarray
    triangles: np.ndarray
    tets: np.ndarray
    scene_toml: str
    params: dict
    status: str
    skin: object = None
    """The :class:`~jellysim.skin.Skin` carried by the run, or ``None``."""

    @property
    def frame_count(self) -> int:
        return int(self.positions.shape[0])

    @property
    def point_count(self) -> int:
        return int(self.positions.shape[1])

    def skin_positions(self, frame: int | None = None) -> np.ndarray | None:
        """Skin vertex positions [m]: shape (m, 3) for one ``frame``, (F, m, 3) for all
        frames (``frame=None``); ``None`` when the trajectory has no skin."""
        if self.skin is None:
            return None
        n = len(self.positions)
        if isinstance(frame, (int, np.integer)) and not -n <= frame < n:
            raise IndexError(f"frame {frame} out of range: the trajectory has {n} frames "
                             f"(0 .. {n - 1}, or -1 for the last)")
        x = self.positions if frame is None else self.positions[frame]
        return self.skin.deform(x, **self._skin_bounds)

    @functools.cached_property
    def _skin_bounds(self) -> dict:
        """:func:`skin_bounds` of the run, packed once (renders and exports ask per frame)."""
        return skin_bounds(self.params)


def resolve_trajectory(path) -> Path:
    """The file or stream directory a trajectory argument names.

    Accepted: a ``trajectory.npz`` file; a stream directory (``trajectory.stream``, see
    :mod:`jellysim.io.stream`); a run's output directory (its stream if it has one, being the
    newer, else its ``trajectory.npz``); a missing ``.npz`` whose directory holds a stream (a
    run that was interrupted or killed before it could write the ``.npz``)."""

    path = Path(path)
    if path.is_dir():
        if (path / "meta.npz").is_file():
            return path
        # a stream beside a .npz is a finished run being extended (or an extension that was
        # stopped): it holds the .npz's frames and more
        for cand in (path / STREAM_DIR, path / "trajectory.npz"):
            if cand.exists() and (cand.suffix == ".npz" or (cand / "meta.npz").is_file()):
                return cand
        from .lock import writer_of

        if (writer := writer_of(path)) is not None:  # (a run building its body: no frame yet)
            raise JellysimError(f"{path}: a run ({writer}) is starting here and has written no "
                                "frame yet; look again in a moment")
        if (path / STREAM_DIR).is_dir():
            raise JellysimError(f"{path / STREAM_DIR}: damaged: its meta.npz is missing (the "
                                "frames cannot be read without it); run it again with "
                                "--overwrite")
        if (path / "body.pvd").is_file():  # (a run under mpiexec killed before it saved)
            raise JellysimError(f"{path}: holds ParaView frames (body.pvd) but no trajectory: "
                                "a run stopped before it saved one (killed under mpiexec?); "
                                "ParaView opens body.pvd, the frames cannot be rendered or "
                                "exported here")
        raise JellysimError(f"{path}: directory holds no trajectory.npz and no {STREAM_DIR} "
                            "(not a run's folder: `jellysim run SCENE --out FOLDER` makes one)")
    if not path.exists() and (path.parent / STREAM_DIR / "meta.npz").is_file():
        return path.parent / STREAM_DIR
    if not path.exists():
        raise JellysimError(f"{path}: trajectory file not found (give a run's folder or its "
                            "trajectory.npz: `jellysim run SCENE --out FOLDER` makes one)")
    return path


def _not_a_trajectory(path, what: str):
    raise JellysimError(f"{path}: {what}, not a trajectory: run it first (jellysim run SCENE "
                        "--out DIR; a scene takes a body file as [body] type = 'file', a mesh "
                        "as type = 'mesh') and give DIR or its trajectory.npz")


def load_trajectory(path, *, mmap: bool = False) -> Trajectory:
    """Read a trajectory written by :class:`Recorder`, by a run (``trajectory.npz``) or a run's
    stream of frames (interrupted or killed runs), see :func:`resolve_trajectory`.

    ``mmap``: stream directories only: map the per-frame arrays read-only from disk instead of
    reading them (memory independent of the frame count)."""

    path = resolve_trajectory(path)
    from ..geometry.mesh import MESH_SUFFIXES

    suffix = path.suffix.lower()
    if suffix in (".jello", ".toml") or suffix in MESH_SUFFIXES - {".vtu"}:  # (.vtu: a frame)
        _not_a_trajectory(path, {".jello": "a body file", ".toml": "a scene"}.get(suffix,
                                                                                  "a mesh"))
    try:
        if path.is_dir():
            d = read_stream(path, mmap=mmap)
        else:
            check_npz(path)
            with np.load(path, allow_pickle=False) as z:
                d = {k: z[k] for k in z.files}
    except FileNotFoundError as exc:
        raise JellysimError(f"{path}: trajectory incomplete ({exc.filename} not found)") from None
    except (OSError, ValueError, KeyError, SyntaxError, EOFError, zipfile.BadZipFile,
            NotImplementedError) as exc:
        raise JellysimError(f"{path}: not a jellysim trajectory ({exc})") from None
    missing = {"positions", "times", "springs", "params_json"} - set(d)
    if missing and {"points", "springs"} <= set(d):
        _not_a_trajectory(path, "a body file (.npz)")
    if missing:
        raise JellysimError(f"{path}: not a jellysim trajectory (missing {sorted(missing)})")
    if path.is_dir() and len(d["times"]) == 0:
        raise JellysimError(f"{path}: the run was stopped before its first frame was "
                            "flushed: no frame to read")
    return Trajectory(
        positions=d["positions"], velocities=d["velocities"], times=d["times"],
        steps=d["steps"], rest_positions=d["rest_positions"], masses=d["masses"],
        springs=d["springs"], rest_length=d["rest_length"], stiffness=d["stiffness"],
        gravity=d["gravity"], triangles=d["triangles"], tets=d["tets"],
        scene_toml=str(d["scene_toml"]), params=json.loads(str(d["params_json"])),
        status=str(d["status"]), skin=_skin(d))


def _skin(d):
    return Skin.from_arrays(d)


def skin_bounds(params: dict) -> dict:
    """What a run's skin is kept out of, from its scene ``params``: the keywords ``floor``
    (the ground's height [m], or ``None``) and ``obstacles`` (its ``[[obstacle]]`` tables
    packed, ``(kind, data)``, or ``None``) of :meth:`jellysim.skin.Skin.deform`."""
    params = params or {}
    ground = params.get("ground") or {}
    floor = float(ground.get("height", 0.0)) if ground.get("enabled", False) else None
    tables = params.get("obstacle") or []
    if not tables:
        return {"floor": floor, "obstacles": None}
    from ..physics.contact import pack_obstacles
    from ..scene_obstacles import make_obstacle

    return {"floor": floor, "obstacles": pack_obstacles([make_obstacle(t) for t in tables])}

