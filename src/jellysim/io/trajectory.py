"""Trajectories: positions per frame plus everything needed to interpret them, in one ``.npz``.

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
``params_json``    str             every resolved parameter, as JSON
``status``         str             ``"complete"`` or ``"failed: <message>"``
=================  ==============  =============================================

Optional skin (:mod:`jellysim.skin`; absent in older files, which load with ``skin = None``):

======================  ==========  ===========================================
``skin_rest_vertices``  (m, 3) f8   skin vertices at rest [m]
``skin_faces``          (f, 3) i8   skin triangles
``skin_point_index``    (m, 4) i8   the four points each skin vertex follows
``skin_weights``        (m, 4) f8   their weights (rows sum to 1)
======================  ==========  ===========================================
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .atomic import atomic_path

__all__ = ["Recorder", "Trajectory", "load_trajectory"]


class Recorder:
    """Collects frames of one run in memory and writes them as one ``.npz``."""

    def __init__(self, model, *, scene_text: str = "", params: dict | None = None,
                 skin=None):
        self.model = model
        self.skin = skin
        self.scene_text = scene_text
        self.params = params or {}
        self.positions: list[np.ndarray] = []
        self.velocities: list[np.ndarray] = []
        self.times: list[float] = []
        self.steps: list[int] = []

    def record(self, state) -> None:
        self.positions.append(state.x.copy())
        self.velocities.append(state.v.copy())
        self.times.append(float(state.t))
        self.steps.append(int(state.step))

    def save(self, path, *, status: str = "complete") -> Path:
        m = self.model
        body = m.body
        empty3 = np.zeros((0, 3), dtype=np.int64)
        empty4 = np.zeros((0, 4), dtype=np.int64)
        n = m.particle_count
        extra = self.skin.arrays() if self.skin is not None else {}
        with atomic_path(path) as tmp:
            with open(tmp, "wb") as fh:
                np.savez_compressed(
                    fh,
                    positions=np.asarray(self.positions, dtype=np.float64).reshape(-1, n, 3),
                    velocities=np.asarray(self.velocities, dtype=np.float64).reshape(-1, n, 3),
                    times=np.asarray(self.times, dtype=np.float64),
                    steps=np.asarray(self.steps, dtype=np.int64),
                    rest_positions=m.particle_x0, masses=m.particle_mass,
                    springs=m.spring_ij, rest_length=m.spring_rest_length,
                    stiffness=m.spring_stiffness, gravity=m.gravity,
                    triangles=body.triangles if body.triangles is not None else empty3,
                    tets=body.tets if body.tets is not None else empty4,
                    scene_toml=np.array(self.scene_text),
                    params_json=np.array(json.dumps(self.params, sort_keys=True)),
                    status=np.array(status), **extra)
        return Path(path)


@dataclass
class Trajectory:
    """A loaded trajectory; attributes as in the module table."""

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
        x = self.positions if frame is None else self.positions[frame]
        return self.skin.deform(x)


def load_trajectory(path) -> Trajectory:
    """Read a trajectory written by :class:`Recorder`."""
    from ..errors import JellysimError

    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            d = {k: z[k] for k in z.files}
    except FileNotFoundError:
        raise JellysimError(f"{path}: trajectory file not found") from None
    except (OSError, ValueError) as exc:
        raise JellysimError(f"{path}: not a jellysim trajectory ({exc})") from None
    missing = {"positions", "times", "springs", "params_json"} - set(d)
    if missing:
        raise JellysimError(f"{path}: not a jellysim trajectory (missing {sorted(missing)})")
    return Trajectory(
        positions=d["positions"], velocities=d["velocities"], times=d["times"],
        steps=d["steps"], rest_positions=d["rest_positions"], masses=d["masses"],
        springs=d["springs"], rest_length=d["rest_length"], stiffness=d["stiffness"],
        gravity=d["gravity"], triangles=d["triangles"], tets=d["tets"],
        scene_toml=str(d["scene_toml"]), params=json.loads(str(d["params_json"])),
        status=str(d["status"]), skin=_skin(d))


def _skin(d):
    from ..skin import Skin

    return Skin.from_arrays(d)
