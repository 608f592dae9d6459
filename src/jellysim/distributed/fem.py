"""The physical (FEM) path over MPI ranks, bitwise equal to the serial run.

A rank holds its owned points, one ghost layer (every corner of a tet that touches an owned
point, and the spring neighbours when springs carry force) and **every tet that touches an
owned point**, in the global relative order of points and tets.  A tet on a partition boundary
is therefore held (and computed) by every rank owning one of its corners, each with its own
copy of the tet's damping strain ``q``: they start equal and are updated from equal positions,
so they stay equal, and no force or ``q`` is ever communicated.  Each owned point gathers its
tets' corner forces through a local CSR list in tet order, i.e. the serial order, so its force,
velocity and position are bitwise the serial ones.  After each substep the owners send the
x, v, a of the ghosts' points (one ``Isend``/``Irecv`` per neighbouring rank), and the run status
of the owned points is agreed by one ``Allreduce``.

Agreed by all ranks: the substep count (the serial stability estimate, computed once on rank 0),
a blow-up and its retry with doubled substeps (:attr:`Simulator.MAX_SUBSTEP_DOUBLINGS`, from the
same chunk start as serially), the smallest tet volume ratio (``Allreduce`` MIN) and the collapse
check (the body's thinness from moments reduced over the ranks).  Handles (pins, pin paths,
point forces, gravity scale, drag) take *global* point indices and are set on every local copy
of a point, owned or ghost.
"""
from __future__ import annotations

import dataclasses
import types
import warnings

import numpy as np

from ..errors import SceneError
from ..kernels import STATUS_OK
from ..params import Integrator
from ..physical_stepping import PhysicalStepping
from ..simulator import (COLLAPSE_MIN_POINTS, PHYSICAL_PARALLEL_MIN_TETS, Simulator,
                         StabilityWarning)
from ..handles import (DRAG_DAMPING_RATIO, Handles, PinPath, advance_releasing, drag_damping,
                       drop_releases, release_step)
from .partition import partition_points, point_graph

__all__ = ["coupling_pairs", "local_fem", "PhysicalMethods"]


def coupling_pairs(model) -> np.ndarray:
    """Point pairs whose forces couple in one substep of the physical path: the six edges of
    every tet, plus the springs when any spring has a stiffness; shape (m, 2), int64 (may
    repeat a pair).  Their graph gives the partition (METIS) and the one ghost layer."""
    t = np.asarray(model.fem.tets, dtype=np.int64)
    edges = [t[:, [a, b]] for a, b in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))]
    if model.spring_count and np.any(model.spring_stiffness != 0):
        edges.append(np.asarray(model.spring_ij, dtype=np.int64))
    return np.concatenate(edges)


def local_fem(fem, glob: np.ndarray, owned_global: np.ndarray):
    """The :class:`~jellysim.physics.fem.FemArrays` of one rank: the tets with an owned corner
    (``owned_global``: bool, shape (n,)), in global order, corners renumbered to the local
    points ``glob`` (sorted global indices, which must hold every corner), and the per-point
    CSR gather list rebuilt (tet order within each point, as serially).  Also returns the
    global indices of the local tets."""
    tets = np.asarray(fem.tets, dtype=np.int64)
    sel = np.flatnonzero(owned_global[tets].any(axis=1))
    local_of = np.full(owned_global.shape[0], -1, dtype=np.int64)
    local_of[glob] = np.arange(glob.size)
    lt = local_of[tets[sel]]
    if lt.size and lt.min() < 0:
        raise AssertionError("a local tet has a corner that is not a local point")
    corner = lt.ravel()
    order = np.argsort(corner, kind="stable")
    ptr = np.zeros(glob.size + 1, dtype=np.int64)
    np.cumsum(np.bincount(corner, minlength=glob.size), out=ptr[1:])

    def frozen(a, dtype):
        a = np.ascontiguousarray(a, dtype=dtype)
        a.setflags(write=False)
        return a

    sliced = {name: frozen(getattr(fem, name)[sel], np.float64)
              for name in ("rest_inverse", "rest_volume", "mu", "lam", "alpha", "mu_lame",
                           "lam_lame")}
    return dataclasses.replace(fem, tets=frozen(lt, np.int32), point_tet_ptr=frozen(ptr, np.int64),
                               point_tet_slot=frozen(order, np.int64), **sliced), sel


class PhysicalMethods(PhysicalStepping):
    """The physical path of :class:`~.simulator.DistributedSimulator` (mixed in)."""

    oversubscribed = None
    """Why the threads asked for each rank exceed the node's cores (a message), or None."""

    physical = False

    # -- setup ------------------------------------------------------------------------------
    def _init_physical(self, model, state, owner, partition, integrator, provot, backend,
                       threads, substeps):
        from .local import LocalPart
        from .simulator import on_root

        if Integrator(integrator) is not Integrator.SYMPLECTIC:
            raise SceneError(
                f"a body with a physical (FEM) material is integrated by symplectic substeps "
                f"(integrator = 'symplectic', the default); got '{Integrator(integrator).value}'")
        if provot.enabled:
            raise SceneError("Provot strain limiting is not used by the physical (FEM) path: "
                             "its tets keep their shape; disable it")
        if str(backend) not in ("numba", "Backend.NUMBA"):
            raise SceneError(f"backend = {str(backend)!r}: the physical (FEM) path runs on "
                             "backend = 'numba' under mpiexec")
        rank, size, n = self.rank, self.size, self.info.n
        self.physical = True
        self.replicated = None
        self.integrator = Integrator.SYMPLECTIC
        self.needed_substeps = on_root(self.comm, lambda: Simulator._auto_substeps(model,
                                                                                     self.dt))
        self.substeps = self.needed_substeps if substeps == "auto" else int(substeps)
        if self.substeps < 1:
            raise SceneError(f"substeps must be an integer >= 1 or 'auto', got {substeps}")
        if self.substeps < self.needed_substeps and rank == 0:
            warnings.warn(
                f"substeps = {self.substeps} gives a substep of {self.dt / self.substeps:.3g} s, "
                f"above the physical path's stable substep "
                f"{self.dt / self.needed_substeps:.3g} s for this material and mesh: use "
                f"substeps >= {self.needed_substeps} (or 'auto')", StabilityWarning, stacklevel=3)
        self.dt_step = self.dt / self.substeps
        cache = {}

        def graph():  # built once, where the model is
            if "graph" not in cache:
                pairs = coupling_pairs(model)
                cache["pairs"], cache["graph"] = pairs, point_graph(n, pairs)
            return cache["graph"]

        self._set_owner(owner, lambda: (graph(), partition_points(
            model.point_x0, cache["pairs"], size, method=partition))[1])

        def build(r):
            part = LocalPart(model, self.owner, r, 1, graph=graph())
            fem, part.tets_global = local_fem(model.fem, part.glob, self.owner == r)
            part.model = dataclasses.replace(part.model, fem=fem)
            return part

        self.depth = 1
        self.part, self.state = self._distribute(build, model, state)
        cache.clear()
        part = self.part
        self.local_model = m = part.model
        fem = m.fem
        share = self._node_threads(threads)  # (collective; says where the node is overrun)
        if threads is None:
            threads = 1 if self.info.tet_count < PHYSICAL_PARALLEL_MIN_TETS else share
        else:
            threads = share
        self.threads = int(threads)
        t_local = fem.tet_count
        self._q = np.zeros((t_local, 6))
        self._tet_force = np.zeros((4 * t_local, 3))
        self._tet_j = np.ones(t_local)
        self._fsum = np.zeros((part.glob.size, 3))
        self._slip = np.zeros(part.glob.size)  # contact slip [m] of the local points
        self._scalar = np.zeros(m.spring_count)
        self._min_j = np.ones(1)
        self._squeezed = np.zeros(1, dtype=np.int8)  # see Simulator._advance_physical
        self._relax = np.array([0, self.substeps], dtype=np.int64)  # (the same)
        self.substeps_taken = self.substeps
        self.min_tet_volume_ratio = 1.0
        """Smallest ``J`` of any tet at any substep so far (agreed by all ranks) [-]."""
        self.handles = Handles.empty(part.glob.size)
        """This rank's handle arrays (local points; set them with :meth:`pin` etc.)."""
        self._global_paths = []
        self._use_springs = self.info.use_springs
        self._total_mass = self.info.total_mass
        rest = on_root(self.comm, lambda: _rest_thinness(model.point_x0))
        self._rest_thin, self._collapse_check = rest
        self._setup_exchange()

    def _tuples(self, h):
        m, fem = self.local_model, self.local_model.fem
        ft = fem.kernel_tuple(self._q, h)
        springs = (m.spring_ij, m.spring_rest_length, m.spring_stiffness, m.point_first_ptr,
                   m.point_second_ptr, m.spring_second_slot, m.point_second_other,
                   self._use_springs)
        model_arrays = (m.point_inv_mass, float(m.damping), m.gravity, springs)
        contact = (self._obstacle_kind, self._obstacle_data, float(self.rest_speed),
                   self.center, float(self.runaway_distance**2), self._slip)
        scratch = (self._tet_force, self._tet_j, self._fsum, self._scalar, self._min_j)
        return model_arrays, ft, contact, scratch

    # -- stepping (the serial frame loop, PhysicalStepping._advance_physical, with these hooks)
    def _physical_chunk(self, nsteps, dt):
        return self._substeps(nsteps, dt)

    def _agreed_min_j(self, value) -> float:
        from mpi4py import MPI

        mj = np.array([float(value)])
        self.comm.Allreduce(MPI.IN_PLACE, mj, op=MPI.MIN)
        return float(mj[0])

    def _announce(self, message) -> None:
        if self.rank == 0:
            warnings.warn(message, StabilityWarning, stacklevel=5)

    def _substeps(self, nsteps, dt):
        import numba

        from .fem_kernels import local_physical_substep

        s = self.state
        model_arrays, ft, contact, scratch = self._tuples(dt)
        hd = self.handles.tuple()
        owned = self.part.owned_local
        previous = numba.get_num_threads()
        numba.set_num_threads(max(1, min(self.threads, numba.config.NUMBA_NUM_THREADS)))
        try:
            for i in range(nsteps):
                status = local_physical_substep(dt, (i + 1.0) / nsteps, s.x, s.v, s.a,
                                                model_arrays, ft, hd, contact, scratch, owned)
                status = self._agree(status)
                if status != STATUS_OK:
                    return i + 1, status
        finally:
            numba.set_num_threads(previous)
        return nsteps, STATUS_OK

    # -- the collapse check, from reduced moments --------------------------------------------
    def _thinness(self) -> float:
        """The body's smallest principal standard deviation [m], from the owned points'
        moments summed over the ranks (two passes: mean, then centred second moments; the
        same value on every rank, see :meth:`_global_sum`)."""
        x = self.state.x[self.part.owned_local]
        s1 = self._global_sum(np.concatenate([[x.shape[0]], x.sum(axis=0)]))
        n, mean = s1[0], s1[1:] / s1[0]
        r = x - mean
        c = self._global_sum((r.T @ r).ravel()).reshape(3, 3) / max(n - 1.0, 1.0)
        return float(np.sqrt(max(np.linalg.eigvalsh(c)[0], 0.0)))

    def _global_sum(self, values) -> np.ndarray:
        """Sum over the ranks of ``values`` (float64, shape (m,)), added in rank order after
        an ``Allgather``: bitwise the same on every rank, whatever MPI's reduction order (a
        decision taken on it - a CG loop's end, a collapse - is then the same everywhere)."""
        mine = np.ascontiguousarray(values, dtype=np.float64)
        every = np.empty((self.size, mine.size))
        self.comm.Allgather(mine, every)
        out = every[0].copy()
        for r in range(1, self.size):
            out += every[r]
        return out

    def _check_collapse(self, before, steps):
        """:meth:`Simulator._check_collapse` with the thinness reduced over the ranks (the
        same value everywhere) and the error built on rank 0."""
        from .simulator import raise_agreed

        if before is None or steps <= 0 or before < 0.25 * self._rest_thin:
            return
        after = self._thinness()
        view = types.SimpleNamespace(
            _rest_thin=self._rest_thin,
            state=types.SimpleNamespace(step=self.step, t=self.t, x=None),
            _thinness=lambda x: after, integrator=self.integrator, model=self.model,
            stability=self.stability, dt_step=self.dt_step, implicit=self.implicit)
        raise_agreed(self.comm, lambda: Simulator._check_collapse(view, before, steps))

    # -- force gauges (collective) -----------------------------------------------------------
    @property
    def _force_model(self):
        return self.local_model

    def _gauge(self, forces, rows) -> np.ndarray:
        """``pin_force()`` / ``drag_force()`` over the ranks, collective calls (every rank
        makes them and gets the same figure): each rank sums its *owned* points of ``rows``,
        whose forces are whole on it (it holds every tet of its points), and the sums are
        added in rank order (:meth:`_global_sum`)."""
        self._require_physical("the force gauges (pin_force, drag_force)")
        owned = np.zeros(self.part.glob.size, dtype=bool)
        owned[self.part.owned_local] = True
        return self._global_sum(forces[rows & owned].sum(axis=0))

    # -- handles (global point indices) -----------------------------------------------------
    def _local_rows(self, indices):
        """Local rows of the global ``indices`` held by this rank (owned or ghost), and the
        number of distinct global indices."""
        idx = np.unique(np.asarray(indices, dtype=np.int64))
        pos = np.clip(np.searchsorted(self.part.glob, idx), 0, self.part.glob.size - 1)
        here = self.part.glob[pos] == idx
        return pos[here], idx.size

    def _require_physical(self, what):
        if not self.physical:
            raise SceneError(f"{what} needs the physical path (a body with a FEM material: "
                             "jellysim.physics.policy.physical_model)")

    def pin(self, indices, path=None) -> None:
        """:meth:`Simulator.pin` with global point indices (every rank makes the same call)."""

        self._require_physical("pinning points")
        rows, _ = self._local_rows(indices)
        gidx = np.unique(np.asarray(indices, dtype=np.int64))
        hd = self.handles
        hd.pinned[rows] = 1
        hd.pin_anchor[rows] = self.state.x[rows]
        self.state.v[rows] = 0.0
        paths = [(i, p) for i, p in self._global_paths if not np.isin(i, gidx).any()]
        if path is not None:
            path = path if isinstance(path, PinPath) else PinPath.of(path)
            paths.append((gidx, path.starting_at(float(self.state.t))))
        self._set_paths(paths)

    def _set_paths(self, paths):
        """Pin paths over global indices; the handles get the local rows of each."""
        self._global_paths = paths
        local = [(self._local_rows(i)[0], p) for i, p in paths]
        self.handles.paths = [(r, p) for r, p in local if r.size]

    def unpin(self, indices=None) -> None:
        """Release pinned points (global indices; all when ``None``)."""
        hd = self.handles
        if indices is None:
            hd.pinned[:] = 0
            self._set_paths([])
            return
        gidx = np.unique(np.asarray(indices, dtype=np.int64))
        hd.pinned[self._local_rows(gidx)[0]] = 0
        self._set_paths([(i, p) for i, p in self._global_paths if not np.isin(i, gidx).any()])

    def apply_force(self, indices, force, *, total: bool = True,
                    until: float | None = None) -> None:
        """:meth:`Simulator.apply_force` with global point indices (``until``: released at
        that time [s], on the nearest step, every rank alike)."""
        self._require_physical("point forces")
        rows, count = self._local_rows(indices)
        f = np.asarray(force, dtype=np.float64).reshape(3)
        release = None if until is None else release_step(until, self.dt, self.step, self.t)
        drop_releases(self, rows)  # a force replaced on these points keeps no earlier release
        if release is not None:
            self.__dict__.setdefault("_releases", []).append((release, rows))
        self.handles.point_force[rows] = f / count if total else f

    def _advance_scheduled(self, steps: int, chunk) -> None:
        """``chunk(n)`` until ``steps`` are taken, stopping where a timed force ends."""
        advance_releasing(self, steps, lambda: self.step, chunk)

    def set_gravity_scale(self, indices, scale: float) -> None:
        """:meth:`Simulator.set_gravity_scale` with global point indices."""
        self._require_physical("a gravity scale")
        self.handles.gravity_scale[self._local_rows(indices)[0]] = float(scale)

    def drag(self, point, target=None, stiffness: float | None = None, *,
             damping_ratio: float = DRAG_DAMPING_RATIO) -> None:
        """:meth:`Simulator.drag` with a global point index (the one point, not a patch)."""
        self._require_physical("dragging")
        d = self.handles.drag
        if point is None:
            d[0] = -1.0
            self.handles.drag_weight[:] = 0.0
            return
        if stiffness is None:
            stiffness = self._total_mass * float(np.linalg.norm(self.info.gravity)) / 0.01
        rows, _ = self._local_rows([int(point)])
        d[0] = float(rows[0]) if rows.size else -1.0
        d[1:4] = np.asarray(target, dtype=np.float64).reshape(3)
        d[4] = float(stiffness)
        d[5] = drag_damping(float(stiffness), self._total_mass, float(damping_ratio))
        self.handles.drag_weight[:] = 0.0   # (under MPI the one point, not a patch)
        self.handles.drag_weight[rows] = 1.0
        self.handles.drag_offset[:] = 0.0


def _rest_thinness(x0):
    """``(rest thinness [m], whether the collapse check applies)`` as the serial Simulator."""

    n = x0.shape[0]
    spread = np.sqrt(np.maximum(np.linalg.eigvalsh(np.cov(x0, rowvar=False)), 0.0)) if (
        n >= COLLAPSE_MIN_POINTS) else np.zeros(3)
    return float(spread[0]), bool(n >= COLLAPSE_MIN_POINTS and spread[0] > 0.1 * spread[2])

