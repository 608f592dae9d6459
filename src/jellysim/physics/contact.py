"""Contact with static obstacles: planes, spheres and axis-aligned boxes.

Each point of the body is a contact point.  After each step (:func:`contact` kernels in
:mod:`jellysim.kernels`), a point found inside an obstacle is moved back to its surface along
the surface normal, and its velocity is changed as a rigid point hitting the obstacle:

* **restitution**: an approaching normal velocity ``v_n < 0`` becomes ``-e v_n``.  Below the
  *rest speed* (default ``2 |g| dt``: what gravity adds in two steps) the contact is resting
  and ``v_n`` becomes 0, so a body lying on the ground does not jitter;
* **Coulomb friction**: the normal impulse per unit mass ``dv_n = v_n' - v_n`` allows a
  tangential impulse of at most ``mu dv_n``.  If the tangential velocity is below
  ``mu_s dv_n`` it is removed (static friction, the point sticks), otherwise it is reduced by
  ``mu_k dv_n`` (kinetic friction).  On a resting contact ``dv_n`` is the normal velocity that
  gravity and the springs added during the step, so this is Coulomb's law ``|F_t| <= mu F_n``
  in impulse form: a point on a plane tilted by t stays put for ``tan t <= mu_s`` and otherwise
  slides with ``a = g (sin t - mu_k cos t)``;
* the tangential position follows the corrected velocity (``x += (v_t' - v_t) dt``), so a
  sticking point does not creep down a slope.

The report's ground (``GroundModel.PAPER``: no normal force, friction by a velocity factor)
stays available; it is not this model.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SceneError, ParameterError
from ..kernels.records import OBSTACLE_COLUMNS, OBSTACLE_MU_S  # (mu_s inf: no slip)
from ..params import (CONTACT_FRICTION, CONTACT_RESTITUTION, CONTACT_SLIP_DISTANCE,
                      _user_stacklevel)

__all__ = ["Plane", "Sphere", "Box", "pack_obstacles", "ground_plane", "OBSTACLE_KINDS"]

OBSTACLE_KINDS = {"plane": 0, "sphere": 1, "box": 2}


@dataclass(frozen=True, kw_only=True)
class _Surface:
    restitution: float = CONTACT_RESTITUTION
    """Coefficient of restitution e in [0, 1]."""
    friction: float = CONTACT_FRICTION
    """Kinetic Coulomb coefficient mu_k >= 0."""
    static_friction: float | None = None
    """Static Coulomb coefficient mu_s >= mu_k (default: ``friction``)."""
    slip_distance: float = CONTACT_SLIP_DISTANCE
    """Slip-weakening distance D_c [m] >= 0: a point's coefficient falls from mu_s to mu_k over
    this much slip (linearly) and is mu_s again once it sticks."""
    no_slip: bool = False
    """A point in contact never moves along the surface (adhesion: a wet plate); it can still
    lift off.  Stored as an infinite static coefficient; explicit integrators only."""

    def __post_init__(self):
        self.row()  # (checked when made: a bad value is refused here, not by the Simulator)

    def _material(self):
        mu_s = self.friction if self.static_friction is None else self.static_friction
        if self.no_slip:
            mu_s = np.inf
        if not 0.0 <= self.restitution <= 1.0:
            raise ParameterError(f"restitution must lie in [0, 1], got {self.restitution}")
        if not self.friction >= 0.0:
            raise ParameterError(f"friction must be >= 0, got {self.friction}")
        if not mu_s >= self.friction:
            raise ParameterError(f"static friction ({mu_s}) must be >= kinetic friction "
                             f"({self.friction})")
        if not (isinstance(self.slip_distance, (int, float, np.number))
                and 0.0 <= self.slip_distance < np.inf):
            raise ParameterError(f"slip_distance must be a length >= 0 [m], got "
                                 f"{self.slip_distance!r}")
        return [float(self.restitution), float(mu_s), float(self.friction),
                float(self.slip_distance)]


def _v3(value, what) -> np.ndarray:
    try:
        return np.asarray(value, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        raise ParameterError(f"{what} must be 3 numbers (x, y, z), got {value!r}") from None


@dataclass(frozen=True, kw_only=True)
class Plane(_Surface):
    """The half-space behind a plane through ``point`` [m] with outward ``normal``."""

    point: tuple = (0.0, 0.0, 0.0)
    normal: tuple = (0.0, 1.0, 0.0)

    def row(self):
        nrm = _v3(self.normal, "a plane's normal")
        length = float(np.linalg.norm(nrm))
        if not np.all(np.isfinite(nrm)):
            raise ParameterError(f"a plane's normal must be 3 finite numbers, got "
                                 f"{nrm.tolist()}")
        if not length > 0:
            raise ParameterError("a plane's normal must be a non-zero vector")
        return 0, [*_v3(self.point, "a plane's point [m]"), *(nrm / length),
                   *self._material()]


@dataclass(frozen=True, kw_only=True)
class Sphere(_Surface):
    """A solid ball of ``radius`` [m] around ``center`` [m]."""

    center: tuple = (0.0, 0.0, 0.0)
    radius: float = 1.0

    def row(self):
        if not self.radius > 0:
            raise ParameterError(f"a sphere's radius must be > 0 m, got {self.radius}")
        return 1, [*_v3(self.center, "a sphere's center [m]"), float(self.radius), 0.0, 0.0,
                   *self._material()]


@dataclass(frozen=True, kw_only=True)
class Box(_Surface):
    """A solid axis-aligned box from ``lower`` to ``upper`` [m]."""

    lower: tuple = (0.0, 0.0, 0.0)
    upper: tuple = (1.0, 1.0, 1.0)

    def row(self):
        lo = _v3(self.lower, "a box's lower corner [m]")
        hi = _v3(self.upper, "a box's upper corner [m]")
        if not np.all(hi > lo):
            raise ParameterError(f"a box's upper corner {hi.tolist()} must exceed {lo.tolist()}")
        return 2, [*lo, *hi, *self._material()]


_MATERIAL_DOC = """

    Contact material (keywords, shared by ``Plane``, ``Sphere``, ``Box``): ``restitution`` e in
    [0, 1] (default 0.3, :data:`~jellysim.params.CONTACT_RESTITUTION`); ``friction`` the
    kinetic Coulomb coefficient mu_k >= 0 (default 0.6, ``CONTACT_FRICTION``);
    ``static_friction`` mu_s >= mu_k (``None``, the default: mu_k); ``slip_distance`` D_c [m]
    (default 1e-3, ``CONTACT_SLIP_DISTANCE``): a point's coefficient falls from mu_s to mu_k
    over this much slip and is mu_s again once it sticks; ``no_slip`` (default
    ``False``): a touching point never moves along the surface but can lift off (mu_s = inf;
    explicit integrators only, the implicit one refuses it).  A value out of range is a
    :class:`~jellysim.errors.ParameterError` (a ``ValueError``) when the obstacle is made."""
for _cls in (Plane, Sphere, Box):
    _cls.__doc__ += _MATERIAL_DOC


def pack_obstacles(obstacles) -> tuple[np.ndarray, np.ndarray]:
    """Kernel arrays for ``obstacles``: kinds, shape (m,), int32 (0 plane, 1 sphere, 2 box), and
    data, shape (m, 10), float64: 6 geometry numbers [m] then restitution, mu_s, mu_k [-] and
    the slip-weakening distance [m] (columns :data:`~jellysim.kernels.records.OBSTACLE_E`,
    ``OBSTACLE_MU_S``, ``OBSTACLE_MU_K``, ``OBSTACLE_SLIP``)."""
    rows = [o.row() for o in obstacles]
    for o, (_, values) in zip(obstacles, rows):
        if not np.all(np.isfinite(np.delete(np.asarray(values, float), OBSTACLE_MU_S))):
            raise ParameterError(f"{o!r}: every number of an obstacle must be finite (m, and its "
                             "restitution and friction)")
    kind = np.array([r[0] for r in rows], dtype=np.int32)
    data = np.array([r[1] for r in rows], dtype=np.float64).reshape(len(rows), OBSTACLE_COLUMNS)
    return kind, np.ascontiguousarray(data)


def ground_plane(ground) -> Plane:
    """The contact ground of :class:`~jellysim.params.GroundParams` ``ground`` as a plane."""
    return Plane(point=(0.0, ground.height, 0.0), normal=(0.0, 1.0, 0.0),
                 restitution=ground.restitution, friction=ground.friction,
                 static_friction=ground.static_friction, slip_distance=ground.slip_distance,
                 no_slip=ground.no_slip)


def user_obstacles(obstacles, x0=None, tol: float | None = None) -> tuple:
    """``obstacles`` (one :class:`Plane`/:class:`Sphere`/:class:`Box` or a sequence of them)
    as a tuple, checked: anything else is a ``TypeError``; with ``x0`` (the body's starting
    positions [m], (n, 3)) a body starting inside an obstacle is a ``ValueError`` (the
    contact would throw its points out at once), saying by how much (deeper than ``tol`` [m];
    default a millionth of the body's size)."""
    if isinstance(obstacles, _Surface):
        obstacles = (obstacles,)
    try:
        obstacles = tuple(obstacles)
    except TypeError:
        raise TypeError(f"obstacles must be a list of jellysim.Plane / Sphere / Box, got "
                        f"{type(obstacles).__name__}") from None
    for k, o in enumerate(obstacles):
        if not isinstance(o, _Surface):
            raise TypeError(f"obstacles[{k}] is {o!r}: give a jellysim.Plane, Sphere or Box "
                            "(e.g. js.Sphere(center=(0, 0.05, 0), radius=0.05))")
    if x0 is None or not len(obstacles):
        return obstacles
    x = np.asarray(x0, dtype=np.float64)
    tol = max(1e-9, 1e-6 * float(np.ptp(x, axis=0).max())) if tol is None else tol
    for k, o in enumerate(obstacles):
        depth = depth_inside(o, x)
        inside = depth > tol
        if inside.any():
            raise ParameterError(f"obstacle #{k + 1} ({o!r}): {int(inside.sum())} of "
                             f"{len(x)} points of the body start inside this obstacle (up to "
                             f"{float(depth.max()):.3g} m deep): its contact would throw them "
                             "out at once; move the body or the obstacle")
    return obstacles


def depth_inside(obstacle, x) -> np.ndarray:
    """How deep [m] each point of ``x`` [m], shape (n, 3), lies inside ``obstacle`` (a
    :class:`Plane`, :class:`Sphere` or :class:`Box`): > 0 inside, <= 0 outside."""
    kind, v = obstacle.row()
    x = np.asarray(x, dtype=np.float64)
    if kind == 0:
        return -(x - np.asarray(v[:3])) @ np.asarray(v[3:6])
    if kind == 1:
        return v[3] - np.linalg.norm(x - np.asarray(v[:3]), axis=1)
    return np.minimum(x - np.asarray(v[:3]), np.asarray(v[3:6]) - x).min(axis=1)


def check_ground_placement(x0, height: float) -> None:
    """A body that starts below the ground would be shot out of it by the contact rule (a
    point below the plane is put on it at once): refuse it, saying by how much and the fix.
    One that starts far above it (over 10 m, and 100 of its sizes) is likely a slip of units
    (millimetres): said, as a warning.  ``x0``: its starting positions [m], (n, 3)."""
    x0 = np.asarray(x0, dtype=np.float64)
    if x0.size == 0:
        return
    low = float(x0[:, 1].min())
    extent = float(np.ptp(x0, axis=0).max())
    if low < height - max(1e-9, 1e-6 * extent):
        below = int(np.sum(x0[:, 1] < height))
        raise SceneError(
            f"the body starts {height - low:.4g} m below the ground (its lowest point at "
            f"y = {low:.4g} m, the ground at y = {height:g} m; {below} of {len(x0)} points "
            f"below): the ground would throw it out.  Lift it: [body] base = [0, {height:g}, "
            f"0] (mesh and file bodies) or [body] lower with y >= {height:g} (box fields) in a "
            f"scene; in Python Body.from_mesh(..., base=(0, {height:g}, 0)) or Body.box(lower=(x, "
            f"{height:g}, z), ...); or disable the ground")
    if low > height + max(10.0, 100.0 * extent):
        import warnings

        warnings.warn(f"the body starts {low - height:.4g} m above the ground (positions are in "
                      "metres: a base or lower given in millimetres is a likely slip); it "
                      f"falls for {np.sqrt(2.0 * (low - height) / 9.81):.3g} s before landing",
                      UserWarning, stacklevel=_user_stacklevel())


def start_checks(model, state, ground, obstacles) -> tuple:
    """The checks of a starting body, serial and MPI alike (the global model): not below the
    ground (:func:`check_ground_placement`), not inside an obstacle (:func:`user_obstacles`,
    as a :class:`~jellysim.errors.SceneError`).  A resumed state (past step 0) may rest on
    them with round-off inside and is not checked.  Returns the obstacles as a tuple."""
    from ..model import Model
    from ..state import State

    if not isinstance(model, Model):  # (a Body failed deep inside: session 20's trial)
        hint = (": make the body a model first, js.physical_model(body, js.material("
                "'gelatin')) for jello or js.finalize(body) for the report's springs"
                if type(model).__name__ == "Body" else "")
        raise ParameterError(f"Simulator: model must be a jellysim.Model, got a "
                             f"{type(model).__name__}{hint}")
    if state is not None and not isinstance(state, State):
        raise ParameterError(f"Simulator: state must be a jellysim.State (another run's "
                             f"sim.state, or None: the model at rest), got a "
                             f"{type(state).__name__}")
    fresh = state is None or getattr(state, "step", 0) == 0
    x = None if not fresh else (model.point_x0 if state is None else state.x)
    if x is not None and ground is not None and ground.enabled:
        check_ground_placement(x, float(ground.height))
    if fresh and ground is not None and ground.enabled:
        check_gravity_meets_ground(model.gravity)
    try:
        return user_obstacles(obstacles, x)
    except ValueError as exc:
        raise SceneError(str(exc)) from None


def check_gravity_meets_ground(gravity) -> None:
    """Warn when gravity [m/s^2] (3,) is nonzero but has less than a tenth of its length
    pointing down, -y, onto the ground plane ``y = height`` (tilted gravity on a slope up to
    84 deg is silent): a z-up setup (gravity (0, 0, -9.81)) would slide the body along the
    ground, or off it, for ever (session 16's researcher trial: nothing said)."""
    import warnings

    from ..params import _user_stacklevel

    g = np.asarray(gravity, dtype=np.float64).reshape(3)
    size = float(np.linalg.norm(g))
    if size > 0.0 and -g[1] < 0.1 * size:
        warnings.warn(f"gravity ({g[0]:g}, {g[1]:g}, {g[2]:g}) m/s^2 does not point down onto the "
                      "ground: the ground is the plane y = height, and y is up (a z-up mesh or "
                      "scene: gravity (0, -9.81, 0) with Body.from_mesh(..., up='z') or "
                      "[body] up = 'z'); or disable the ground", UserWarning,
                      stacklevel=_user_stacklevel())
