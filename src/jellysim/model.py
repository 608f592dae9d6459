"""Model: everything that does not change during a run.

:func:`finalize` turns a :class:`~jellysim.body.Body` plus physical constants into a Model once;
the time-step loop then only reads it.  Arrays are read-only (``writeable=False``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .body import Body
from .params import GRAVITY, REPORT_DENSITY
from .state import State
from .errors import ParameterError

__all__ = ["Model", "finalize"]


def _frozen(a: np.ndarray, dtype) -> np.ndarray:
    a = np.ascontiguousarray(a, dtype=dtype)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Model:
    """Read-only description of a mass-spring body (SI units).

    The spring adjacency is stored twice so that per-point sums are race-free gathers
    (every point reads the springs it belongs to, :mod:`jellysim.kernels.spring_sums_numba`):
    springs are sorted by their first point ``i``, so the springs whose first point is ``p`` are
    ``spring_ij[point_first_ptr[p]:point_first_ptr[p+1]]``.  The springs whose *second* point is
    ``q`` occupy the "second-list slots" ``point_second_ptr[q]:point_second_ptr[q+1]``; slot t
    holds spring ``point_second_spring[t]`` whose first point is ``point_second_other[t]``, and
    spring s sits in slot ``spring_second_slot[s]``.  The report's sequential (Gauss-Seidel)
    step computes each spring once and writes its scalar into that slot, so a second pass reads
    them sequentially; the Jacobi paths compute each spring from both ends.
    """

    point_x0: np.ndarray
    """Rest positions [m], shape (n, 3), float64."""
    point_mass: np.ndarray
    """Point masses [kg], shape (n,), float64, all > 0."""
    point_inv_mass: np.ndarray
    """Inverse masses [1/kg], shape (n,), float64."""
    spring_ij: np.ndarray
    """Spring end points, shape (k, 2), int32, ``i < j``, rows unique and sorted."""
    spring_rest_length: np.ndarray
    """Rest lengths [m], shape (k,), float64."""
    spring_stiffness: np.ndarray
    """Stiffness k [N/m], shape (k,), float64."""
    point_first_ptr: np.ndarray
    """CSR offsets [-], shape (n + 1,), int64: springs whose first point is p."""
    point_second_ptr: np.ndarray
    """CSR offsets [-], shape (n + 1,), int64: springs whose second point is q."""
    point_second_spring: np.ndarray
    """Spring index of each second-list slot [-], shape (k,), int32 (see above)."""
    spring_second_slot: np.ndarray
    """Second-list slot of each spring [-], shape (k,), int32: inverse of the above."""
    point_second_other: np.ndarray
    """First point of each entry of ``point_second_spring`` [-], shape (k,), int32."""
    damping: float
    """Velocity damping delta [kg/s] (report eq. 1: force ``-delta v`` on every point)."""
    gravity: np.ndarray
    """Gravitational acceleration [m/s^2], shape (3,), float64."""
    body: Body
    """The body this model was built from (tets, triangles, provenance)."""
    fem: object = None
    """:class:`~jellysim.physics.fem.FemArrays` of the physical material (tet elasticity and
    damping), or ``None`` for a springs-only body."""

    def __repr__(self) -> str:  # (the dataclass's printed every array)
        tets = getattr(self.fem, "tet_count", None)
        return (f"Model({self.point_count} points, {self.spring_count} springs"
                + (f", {tets} FEM tets" if tets is not None else ", springs only")
                + f", {self.total_mass:.6g} kg)")

    @property
    def point_count(self) -> int:
        return int(self.point_x0.shape[0])

    @property
    def spring_count(self) -> int:
        return int(self.spring_ij.shape[0])

    @property
    def total_mass(self) -> float:
        """Total mass [kg]."""
        return float(self.point_mass.sum())

    def state(self):
        """A new :class:`~jellysim.state.State` at rest positions, zero velocity, with
        accelerations evaluated from the forces (so ``state.a`` is consistent at t = 0)."""

        return State.at_rest(self)


def finalize(
    body: Body,
    *,
    stiffness=None,
    density: float | None = None,
    volume: float | None = None,
    point_mass: float | None = None,
    damping: float = 0.0,
    gravity=GRAVITY,
) -> Model:
    """Freeze a body into a :class:`Model`.

    Parameters
    ----------
    body: points, springs and optional per-spring/per-point data.
    stiffness: spring stiffness k [N/m]: one number for every spring, or an array of shape
        (k,), one per row of ``body.springs`` (e.g. from
        :func:`jellysim.physics.material.calibrate_springs`).  Needed unless
        ``body.stiffness`` is set; giving both is an error when they differ.
    density: [kg/m^3] (default: the density the body was built at, ``body.meta["density"]``,
        else :data:`~jellysim.params.REPORT_DENSITY`), used when neither ``body.masses`` nor
        ``point_mass`` is given: total mass = density x volume (``volume`` argument, else
        ``body.volume``), split evenly; another density than the body was built at is used,
        with a warning.  When ``body.masses`` is
        already set (tet bodies from :func:`jellysim.build.build_body` lump density x volume
        at build time, at the size they were built) a ``density`` other than the one the body
        was built with (``body.meta["density"]``) is an error, never silently ignored: build
        the body at its final size and density (``Body.from_mesh(path, size=..., density=...)``)
        or drop its masses (``dataclasses.replace(body, masses=None)``).
    volume: enclosed volume [m^3] overriding ``body.volume`` for the mass split.
    point_mass: mass of every point [kg], overriding density x volume (an error when
        ``body.masses`` is set).
    damping: velocity damping delta [kg/s], >= 0.
    gravity: [m/s^2], shape (3,).
    """
    for name, value, unit in (("stiffness", stiffness, "N/m"), ("density", density, "kg/m^3"),
                              ("volume", volume, "m^3"), ("point_mass", point_mass, "kg"),
                              ("damping", damping, "kg/s"), ("gravity", gravity, "m/s^2")):
        _numeric(name, value, unit)
    points = np.asarray(body.points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] == 0:
        raise ParameterError(f"body points must have shape (n, 3) with n >= 1, got {points.shape}")
    if not np.all(np.isfinite(points)):
        raise ParameterError("body points contain NaN or infinite coordinates")
    n = points.shape[0]
    springs = np.asarray(body.springs, dtype=np.int64).reshape(-1, 2)
    k = springs.shape[0]
    if k and (springs.min() < 0 or springs.max() >= n):
        raise ParameterError(f"spring indices must lie in [0, {n - 1}]")
    if k and np.any(springs[:, 0] >= springs[:, 1]):
        raise ParameterError("every spring row must satisfy i < j")
    order = np.lexsort((springs[:, 1], springs[:, 0]))
    if k and np.any(np.all(np.diff(springs[order], axis=0) == 0, axis=1)):
        raise ParameterError("duplicate springs")

    if body.rest_length is None:
        rest = np.linalg.norm(points[springs[:, 1]] - points[springs[:, 0]], axis=1)
    else:
        rest = np.asarray(body.rest_length, dtype=np.float64).reshape(k)
        if not np.all(np.isfinite(rest) & (rest >= 0)):
            bad = int(np.flatnonzero(~(np.isfinite(rest) & (rest >= 0)))[0])
            raise ParameterError(f"body.rest_length must be >= 0 m and finite for every spring "
                                 f"(spring {bad}: {float(rest[bad])!r}); leave it None to take the "
                                 "springs' start lengths")
    if body.rest_length is None and k and not np.all(rest > 0):
        _say_coincident(springs, rest)
    stiff = _stiffness(body, stiffness, k)
    springs, rest, stiff = springs[order], rest[order], stiff[order]
    mass = _masses(body, n, density, volume, point_mass)
    if not np.all(np.isfinite(mass) & (mass > 0)):
        raise ParameterError("every point mass must be a positive finite number of kg")
    if not (damping >= 0 and np.isfinite(damping)):
        raise ParameterError(f"damping must be >= 0 kg/s, got {damping}")
    if np.shape(gravity) != (3,):
        raise ParameterError(f"gravity must be a vector of 3 accelerations [m/s^2], e.g. (0, "
                             f"-9.81, 0) (y is up), got {gravity!r}")
    gravity = np.asarray(gravity, dtype=np.float64)
    if not np.all(np.isfinite(gravity)):
        raise ParameterError(f"gravity must be 3 finite accelerations [m/s^2], e.g. (0, -9.81, "
                             f"0), got {gravity.tolist()!r}")

    first_ptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(springs[:, 0], minlength=n), out=first_ptr[1:])
    second = np.argsort(springs[:, 1], kind="stable")
    second_ptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(springs[:, 1], minlength=n), out=second_ptr[1:])

    return Model(
        point_x0=_frozen(points, np.float64),
        point_mass=_frozen(mass, np.float64),
        point_inv_mass=_frozen(1.0 / mass, np.float64),
        spring_ij=_frozen(springs, np.int32),
        spring_rest_length=_frozen(rest, np.float64),
        spring_stiffness=_frozen(stiff, np.float64),
        point_first_ptr=_frozen(first_ptr, np.int64),
        point_second_ptr=_frozen(second_ptr, np.int64),
        point_second_spring=_frozen(second, np.int32),
        spring_second_slot=_frozen(np.argsort(second, kind="stable"), np.int32),
        point_second_other=_frozen(springs[second, 0], np.int32),
        damping=float(damping),
        gravity=_frozen(gravity, np.float64),
        body=body,
    )


def _numeric(name: str, value, unit: str) -> None:
    """Refuse text or other non-numbers where finalize needs numbers [``unit``] (numpy would
    read ``stiffness='2'`` as 2.0: notebook trial, session 30)."""
    if value is None:
        return
    bad = isinstance(value, (str, bytes, bool))
    if not bad:
        try:
            kind = np.asarray(value).dtype.kind
        except (TypeError, ValueError):
            kind = "O"
        bad = kind not in "iuf"
    if bad:
        raise ParameterError(f"finalize: {name} must be numeric [{unit}], got "
                             f"{value!r} ({type(value).__name__})")


def _say_coincident(springs, rest) -> None:
    """Warn of springs whose two points start at the same place (a body with duplicate
    points): their rest length is 0, so they pull their points together, and strain limiting
    (a tolerance times the rest length) cannot hold them."""
    import warnings

    zero = np.flatnonzero(rest == 0)
    i = int(zero[0])
    warnings.warn(f"{len(zero)} spring(s) join two points at the same position (the first: "
                  f"springs[{i}] = {springs[i].tolist()}): their rest length is 0 m.  The body "
                  "has duplicate points; remove them (e.g. np.unique(points, axis=0), then build "
                  "the springs), or give body.rest_length", UserWarning, stacklevel=3)


def _stiffness(body: Body, stiffness, k: int) -> np.ndarray:
    """Per-spring stiffness [N/m], shape (k,), in ``body.springs`` order."""
    given = None
    if stiffness is not None:
        given = np.asarray(stiffness, dtype=np.float64)
        if given.ndim == 0:
            given = np.full(k, float(given))
        elif given.shape != (k,):
            raise ParameterError(f"stiffness must be one number or an array of shape ({k},) (one "
                             f"per spring), got shape {given.shape}")
        if not np.all(np.isfinite(given) & (given >= 0)):
            raise ParameterError("stiffness must be >= 0 N/m and finite for every spring")
    if body.stiffness is None:
        if given is None:
            if k:
                raise ParameterError("spring stiffness k [N/m] is not given: pass stiffness= (a "
                                 "number or one per spring) or set body.stiffness")
            given = np.zeros(0)
        return given
    own = np.asarray(body.stiffness, dtype=np.float64).reshape(k)
    if given is not None and not np.allclose(given, own, rtol=1e-12, atol=0.0):
        raise ParameterError("stiffness given, but body.stiffness is already set and differs; "
                         "pass one of them (dataclasses.replace(body, stiffness=None) drops "
                         "the body's)")
    return own


def _masses(body: Body, n: int, density, volume, point_mass) -> np.ndarray:
    """Point masses [kg], shape (n,)."""
    built = body.meta.get("density") if isinstance(body.meta, dict) else None
    if body.masses is not None:
        if point_mass is not None:
            raise ParameterError("point_mass given, but body.masses is already set; drop one "
                             "(dataclasses.replace(body, masses=None) drops the body's)")
        if density is not None and not (built is not None and float(built) == float(density)):
            at = f" at {built:g} kg/m^3" if built is not None else ""
            raise ParameterError(
                f"density={density:g} kg/m^3 given, but body.masses is already set (lumped"
                f"{at} when the body was built, at the size it was built), so it would be "
                "ignored: build the body at its final size and density (Body.from_mesh(path, "
                "size=..., density=...) or build_body(..., size=..., density=...)), or drop "
                "its masses with dataclasses.replace(body, masses=None) to split density x "
                "volume evenly")
        return np.asarray(body.masses, dtype=np.float64).reshape(n)
    if point_mass is None and density is not None and built is not None and float(built) != float(density):
        import warnings

        from .params import _user_stacklevel

        warnings.warn(  # (a radius body's masses are split here: not silently another's)
            f"finalize: density={density:g} kg/m^3, but the body was built at {built:g} "
            f"kg/m^3: its masses are {density:g} x its volume, split evenly (leave density "
            "out to use the body's)", UserWarning, stacklevel=_user_stacklevel())
    if point_mass is not None:
        return np.full(n, float(point_mass))
    density = built if density is None and built is not None else density
    vol = volume if volume is not None else body.volume
    if vol is None:
        raise ParameterError("cannot derive masses: give point masses, point_mass or a volume")
    density = REPORT_DENSITY if density is None else float(density)
    if not (np.isfinite(density) and density > 0):
        raise ParameterError(f"density must be a positive number of kg/m^3, got {density}")
    return np.full(n, density * float(vol) / n)
