"""The backend interface's records: kernel arguments bundled once per model.

A backend (numpy, numba, Warp) implements three drivers,

* ``run_steps(nsteps, dt, integrator, x, v, a, springs, points, provot, ground, obstacles,
  scratch) -> (steps_done, status)`` (the explicit integrators),
* ``implicit_steps(nsteps, dt, x, v, a, springs, points, ground, obstacles, options,
  scratch) -> (steps_done, status, cg_iterations, worst_residual)``, and
* ``physical_steps(nsteps, dt, x, v, a, model_arrays, fem, handles, contact, scratch) ->
  (steps_done, status)`` (the FEM path: :func:`.fem_numpy.physical_steps`, the spec),

(a backend may leave out one whose integrator :func:`jellysim.scene_spec.check_backend`
refuses for it, as Warp does ``implicit_steps``), over the state arrays ``x`` [m], ``v`` [m/s], ``a`` [m/s^2] (n, 3) float64, updated in place, and the records
below.  The :class:`~jellysim.simulator.Simulator` builds the records once
(:func:`spring_arrays`, :func:`point_arrays`, ...) and only ever calls those drivers, so a new
backend, registered in :mod:`jellysim.kernels` (a ``Backend`` member and a ``get_backend``
branch: docs/architecture.md, "The backend interface"), needs no change to the simulator: it
receives the host arrays and may keep device copies keyed on the records it is given (they do
not change during a run, except the state and the scratch).

The records are named tuples of arrays and scalars: numba compiles them in nopython mode as
typed tuples (no speed loss measured, BENCHMARKS.md), numpy reads their fields by name.
"""
from __future__ import annotations

import weakref
from collections import namedtuple

import numpy as np

__all__ = ["OBSTACLE_E", "OBSTACLE_MU_S", "OBSTACLE_MU_K", "OBSTACLE_SLIP", "OBSTACLE_COLUMNS",
           "SpringArrays", "PointArrays", "ProvotOptions", "GroundGuard", "Obstacles",
           "ExplicitScratch", "ImplicitOptions", "ImplicitScratch", "spring_arrays",
           "point_arrays", "visit_lists", "provot_options", "ground_guard", "obstacles",
           "explicit_scratch", "implicit_options", "implicit_scratch"]

SpringArrays = namedtuple("SpringArrays", "ij rest stiff first_ptr second_ptr second_slot "
                                          "second_other first_other visit_ptr visit_other "
                                          "visit_rest visit_stiff")
"""The springs (k of them, sorted by (i, j), i < j): ``ij`` (k, 2) int64, ``rest`` [m] (k,),
``stiff`` [N/m] (k,); the CSR adjacency: ``first_ptr`` (n + 1,) (springs whose first point is
p are ``first_ptr[p]:first_ptr[p+1]``), ``second_ptr`` (n + 1,) into the second-point list,
``second_slot`` (k,) int32 (spring -> its slot in that list), ``second_other`` (k,) int32
(slot -> the spring's first point), ``first_other`` (k,) int32 (spring -> its second point:
``ij[:, 1]`` in 4 bytes); and each point's springs as ONE list, what the per-point sweeps
read (:mod:`.spring_sums_numba`): point p's visits are ``visit_ptr[p]:visit_ptr[p+1]``
(``visit_ptr`` (n + 1,) int64), first the springs p is the first point of (in spring order),
then those it is the second point of (in slot order), each as ``visit_other`` (2k,) int32 (the
spring's other end), ``visit_rest`` [m] and ``visit_stiff`` [N/m] (2k,) float64 (its rest length
and stiffness).  See :class:`jellysim.model.Model`."""

PointArrays = namedtuple("PointArrays", "x0 mass inv_mass damping gravity")
"""Rest positions ``x0`` [m] (n, 3), ``mass`` [kg] (n,), ``inv_mass`` [1/kg] (n,), the damping
``damping`` delta [kg/s] (a float) and ``gravity`` [m/s^2] (3,)."""

ProvotOptions = namedtuple("ProvotOptions", "loops tau tolerance all_pairs gauss_seidel "
                                            "velocity_update")
"""Provot strain limiting: ``loops`` passes per step (0: off), ``tau`` [-], early stop when the
largest correction is <= ``tolerance`` [m], ``all_pairs`` / ``gauss_seidel`` (bools) and
``velocity_update`` (add the correction / dt to v)."""

GroundGuard = namedtuple("GroundGuard", "paper height mu nu center bound2")
"""The report's ground (``paper`` bool; plane ``y = height`` [m], ``mu``, ``nu``) and the
runaway guard: a point farther than ``sqrt(bound2)`` [m] from ``center`` [m] (3,) stops the
run."""

OBSTACLE_E, OBSTACLE_MU_S, OBSTACLE_MU_K, OBSTACLE_SLIP = 6, 7, 8, 9
"""Columns of an obstacle's ``data`` row after its 6 geometry numbers: restitution e, static
and kinetic Coulomb friction coefficients [-], the slip-weakening distance D_c [m]
(:func:`jellysim.physics.contact.pack_obstacles`)."""

OBSTACLE_COLUMNS = 10
"""Numbers per obstacle ``data`` row."""

Obstacles = namedtuple("Obstacles", "kind data rest_speed slip")
"""Static obstacles (:func:`jellysim.physics.contact.pack_obstacles`): ``kind`` (m,) int32,
``data`` (m, :data:`OBSTACLE_COLUMNS`), ``rest_speed`` [m/s] below which a contact rests;
``slip`` (n,) float64 [m], state carried between steps: each point's tangential slip since it
last stuck (its friction weakens from mu_s to mu_k over D_c of slip)."""

ExplicitScratch = namedtuple("ExplicitScratch", "spring_scalar provot_scalar dx count max_corr "
                                                "x_pre v_alt force")
"""Scratch of :func:`run_steps`: (k,), (k,), (n, 3), (n,) int64, (n,); ``x_pre``, ``v_alt``
(n, 3) in the state's dtype (the fused step's second position/velocity buffers) and ``force``
(n, 3) float64 (its partial force sums)."""

ImplicitOptions = namedtuple("ImplicitOptions", "theta tolerance max_iterations bdf2")
"""The implicit step: ``theta`` in [1/2, 1], CG relative ``tolerance`` and ``max_iterations``,
``bdf2`` (bool: the BDF2 scheme instead of the theta-method)."""

ImplicitScratch = namedtuple("ImplicitScratch", "spring_scalar frame spring_vec dv r z p ap "
                                                "diag b cnrm cobs contact_state hist fresh "
                                                "friction")
"""State and scratch of :func:`implicit_steps`: ``spring_scalar`` (k,), ``frame`` (k, 5),
``spring_vec`` (k, 3); ``dv`` (the warm start), ``r z p ap diag b`` (n, 3); ``cnrm`` (n, 6),
``cobs`` (n,) int64, ``contact_state`` (n,) int8 (carried between steps); BDF2 history
``hist`` (4, n, 3) and ``fresh`` (n,) uint8 (carried); ``friction`` (n, 3) [kg m/s]: the
kinetic friction impulse the sliding contact points get inside the solve."""


_SPRING_ARRAYS = weakref.WeakKeyDictionary()
"""Model -> its SpringArrays (built once: the visit lists cost a few scatters over the springs)."""


def spring_arrays(model) -> SpringArrays:
    """The springs record of ``model`` (built once per Model, then reused)."""
    from ..model import _frozen  # (model -> state -> records: imported when called)

    m = model
    try:
        return _SPRING_ARRAYS[m]
    except (KeyError, TypeError):
        pass
    rec = SpringArrays(m.spring_ij, m.spring_rest_length, m.spring_stiffness,
                       m.point_first_ptr, m.point_second_ptr, m.spring_second_slot,
                       m.point_second_other,
                       _frozen(np.asarray(m.spring_ij)[:, 1], np.int32),
                       *visit_lists(m.spring_ij, m.spring_rest_length, m.spring_stiffness,
                                    m.point_first_ptr, m.point_second_ptr,
                                    m.point_second_spring))
    try:
        _SPRING_ARRAYS[m] = rec
    except TypeError:  # not weak-referenceable: built each time
        pass
    return rec


def visit_lists(ij, rest, stiff, first_ptr, second_ptr, second_spring):
    """Each point's springs as one list (:class:`SpringArrays`' ``visit_*`` fields):
    ``(visit_ptr, visit_other, visit_rest, visit_stiff)``, read-only.  Point p's first-list
    springs (``first_ptr[p]:first_ptr[p+1]``, spring order) come first, then its second-list
    slots (``second_ptr[p]:second_ptr[p+1]``, slot t holding spring ``second_spring[t]``).

    Why one list (BENCHMARKS.md, "One list per point"): the sweeps' loops are vectorised 8
    springs at a time, and a point's two lists (17 springs each in the paper scene) left a
    scalar remainder each; one loop of 34 ran the paper scene's sweep 1.28x faster."""
    from ..model import _frozen

    ij = np.asarray(ij)
    first_ptr, second_ptr = np.asarray(first_ptr), np.asarray(second_ptr)
    second_spring = np.asarray(second_spring, dtype=np.int64)
    n, k = first_ptr.shape[0] - 1, ij.shape[0]
    n_first, n_second = np.diff(first_ptr), np.diff(second_ptr)
    visit_ptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(n_first + n_second, out=visit_ptr[1:])
    first_pos = np.arange(k, dtype=np.int64) + np.repeat(visit_ptr[:-1] - first_ptr[:-1], n_first)
    second_pos = np.arange(k, dtype=np.int64) + np.repeat(
        visit_ptr[:-1] + n_first - second_ptr[:-1], n_second)
    other = np.empty(2 * k, dtype=np.int32)
    other[first_pos] = ij[:, 1]
    other[second_pos] = ij[second_spring, 0]
    out = [_frozen(visit_ptr, np.int64), _frozen(other, np.int32)]
    for values in (rest, stiff):
        values = np.asarray(values, dtype=np.float64)
        v = np.empty(2 * k, dtype=np.float64)
        v[first_pos] = values
        v[second_pos] = values[second_spring]
        out.append(_frozen(v, np.float64))
    return tuple(out)


def point_arrays(model) -> PointArrays:
    m = model
    return PointArrays(m.point_x0, m.point_mass, m.point_inv_mass, float(m.damping),
                       np.ascontiguousarray(m.gravity, dtype=np.float64))


def provot_options(loops, tau, tolerance=0.0, all_pairs=False, gauss_seidel=False,
                   velocity_update=False) -> ProvotOptions:
    return ProvotOptions(int(loops), float(tau), float(tolerance), bool(all_pairs),
                         bool(gauss_seidel), bool(velocity_update))


def ground_guard(paper=False, height=0.0, mu=0.1, nu=0.2, center=(0.0, 0.0, 0.0),
                 bound2=np.inf) -> GroundGuard:
    return GroundGuard(bool(paper), float(height), float(mu), float(nu),
                       np.ascontiguousarray(center, dtype=np.float64), float(bound2))


def obstacles(kind=None, data=None, rest_speed=0.0, slip=None) -> Obstacles:
    """``slip`` (n,) float64, one per point, required when there is an obstacle (the kernels
    read it without bounds checks)."""
    kind = np.zeros(0, dtype=np.int32) if kind is None else kind
    data = np.zeros((0, OBSTACLE_COLUMNS)) if data is None else data
    if slip is None:
        if kind.shape[0]:
            raise ValueError("obstacles(): give slip, one float64 per point")
        slip = np.zeros(0)
    return Obstacles(kind, data, float(rest_speed), slip)


def explicit_scratch(n: int, k: int, dtype=np.float64) -> ExplicitScratch:
    """``dtype``: the state's (float64, or float32 for ``precision = "float32"``)."""
    return ExplicitScratch(np.zeros(k), np.zeros(k), np.zeros((n, 3)),
                           np.zeros(n, dtype=np.int64), np.zeros(n), np.zeros((n, 3), dtype),
                           np.zeros((n, 3), dtype), np.zeros((n, 3)))


def implicit_options(theta=1.0, tolerance=1e-3, max_iterations=300, bdf2=False):
    return ImplicitOptions(float(theta), float(tolerance), int(max_iterations), bool(bdf2))


def implicit_scratch(n: int, k: int) -> ImplicitScratch:
    z3 = [np.zeros((n, 3)) for _ in range(7)]  # dv, r, z, p, ap, diag, b
    return ImplicitScratch(np.zeros(k), np.zeros((k, 5)), np.zeros((k, 3)), *z3,
                           np.zeros((n, 6)), np.full(n, -1, dtype=np.int64),
                           np.zeros(n, dtype=np.int8), np.zeros((4, n, 3)),
                           np.ones(n, dtype=np.uint8), np.zeros((n, 3)))
