"""DistributedSimulator: the :class:`~jellysim.simulator.Simulator` API over MPI ranks.

(The physical (FEM) path has its own driver, :mod:`.fem`, mixed in; what follows is the
springs path.)

Every rank holds the global Model (rank 0 builds it and broadcasts, see :mod:`.runner`), owns
a part of the points (:mod:`.partition`) and runs an ordinary ``Simulator`` on its local Model
(owned points + ghost layers, :mod:`.local`) one kernel (sub)step at a time.  After each
(sub)step: the run status is agreed by all ranks (one ``Allreduce``), then every rank sends the
x, v, a of its owned boundary points to the ranks that hold them as ghosts (nonblocking
``Isend``/``Irecv`` between neighbouring ranks only).  The physics does not know about ranks.
"""
from __future__ import annotations

import os
import types
import warnings

import numpy as np

from ..errors import SceneError, SimulationError
from ..kernels import STATUS_NONFINITE, STATUS_OK, STATUS_RUNAWAY
from ..params import GroundModel, GroundParams, ImplicitParams, Integrator, ProvotParams
from ..state import State, clock
from .fem import PhysicalMethods, _rest_thinness
from .local import LocalPart, combine_status, halo_depth, replicated_reason
from .partition import partition_points, point_graph
from ..simulator import Simulator, springs_auto_substeps
from ..physics.contact import ground_plane, pack_obstacles, start_checks

__all__ = ["DistributedSimulator", "on_root", "world", "launched_under_mpi"]

_SIZE_VARS = ("PMI_SIZE", "OMPI_COMM_WORLD_SIZE", "MV2_COMM_WORLD_SIZE", "PMIX_SIZE")


def launched_under_mpi() -> bool:
    """True when this process was started by ``mpiexec -n N`` with N > 1 (read from the
    launcher's environment, without importing MPI)."""
    for var in _SIZE_VARS:
        try:
            if int(os.environ.get(var, "1")) > 1:
                return True
        except ValueError:
            pass
    return False


def world():
    """``MPI.COMM_WORLD`` (imports mpi4py, the ``[mpi]`` extra)."""
    try:
        from mpi4py import MPI
    except ImportError:
        raise SceneError("running under mpiexec needs mpi4py and an MPI library: "
                         "pip install 'jellysim[mpi]'") from None
    return MPI.COMM_WORLD


class AllStopped(KeyboardInterrupt):
    """A Ctrl-C (or SIGTERM) on rank 0 while it worked for every rank (:func:`on_root`),
    raised on every rank: they all end together, none left waiting (no ``MPI_Abort``)."""


def on_root(comm, fn, *, share: bool = True):
    """``fn()`` run on rank 0 and broadcast to every rank (``share=False``: kept on rank 0,
    ``None`` elsewhere); an exception there is raised on every rank (the same type and
    message) instead of leaving the others waiting, an interrupt as :class:`AllStopped`."""
    payload = value = None
    if comm.Get_rank() == 0:
        try:
            value = fn()
            payload = (True, value if share else None)
        except Exception as exc:  # noqa: BLE001 (re-raised on every rank below)
            payload = (False, exc)
        except KeyboardInterrupt:
            payload = (False, AllStopped("interrupted on rank 0"))
    ok, shared = comm.bcast(payload, root=0)
    if not ok:
        raise shared
    return shared if share else value


def raise_agreed(comm, fn) -> None:
    """Run ``fn`` on rank 0; the :class:`SimulationError` it raises (it builds the message
    from the global model) is raised on every rank (the error does not pickle: its message,
    step and status travel)."""
    def build():
        try:
            fn()
        except SimulationError as exc:
            return str(exc), exc.step, exc.status
        return None

    got = on_root(comm, build)
    if got is not None:
        raise SimulationError(got[0], step=got[1], status=got[2])


def body_info(model, runaway_distance) -> types.SimpleNamespace:
    """What every rank needs to know of the global Model (small; computed on rank 0)."""
    x0 = model.point_x0
    if runaway_distance is None:
        diag = float(np.linalg.norm(x0.max(axis=0) - x0.min(axis=0)))
        runaway_distance = max(100.0 * diag, 100.0)
    fem = getattr(model, "fem", None)
    return types.SimpleNamespace(
        n=model.point_count, physical=fem is not None,
        tet_count=0 if fem is None else fem.tet_count,
        center=np.ascontiguousarray(x0.mean(axis=0)), runaway_distance=float(runaway_distance),
        gravity=np.array(model.gravity), total_mass=model.total_mass,
        use_springs=bool(model.spring_count and np.any(model.spring_stiffness != 0)))


_WHOLE_BODY = ("{} needs the whole body, which no rank holds under mpiexec: compute it from "
               "the saved run (jellysim.plot.diagnostics(load_trajectory(OUT)), or jellysim "
               "plot OUT), or run serially; sim.min_tet_volume_ratio, sim.pin_force() and "
               "sim.drag_force() are agreed by every rank")


class DistributedSimulator(PhysicalMethods):
    """Time-steps one global Model split among the ranks of ``comm``.

    Same keyword arguments as :class:`~jellysim.simulator.Simulator`, plus:

    comm: an mpi4py communicator (default ``MPI.COMM_WORLD``).
    partition: ``"morton"`` (contiguous Z-order ranges) or ``"metis"`` (graph partition).
    owner: owner rank of each point, shape (n,) (overrides ``partition``); must be the same
        on every rank.
    threads: numba threads per rank (default: the cores divided among the ranks on the node).

    ``model`` (and ``state``, ``owner``) may be given on rank 0 only (``None`` elsewhere, as
    ``mpiexec jellysim run`` does): rank 0 then builds every rank's part and sends it, and the
    other ranks never hold the global arrays (:attr:`lean`).

    ``state`` is this rank's *local* state (owned points and ghosts, local numbering);
    :meth:`gather` assembles the global one on one rank.  Results (positions, velocities,
    status, the step of a failure) are bitwise equal to a serial run for the explicit
    integrators with Jacobi Provot on springs, and for the physical (FEM) path
    (:mod:`.fem`; handles take global point indices); the configurations listed by
    :func:`~.local.replicated_reason` run the whole body on every rank (equal, no speed-up).
    """

    split_implicit = False

    def __init__(self, model, *, dt: float, comm=None, partition: str = "morton",
                 owner=None, integrator=Integrator.SYMPLECTIC,
                 provot: ProvotParams = ProvotParams(enabled=False),
                 ground: GroundParams = GroundParams(enabled=False), backend="numba",
                 threads: int | None = None, runaway_distance: float | None = None,
                 check_stability: bool = True, state=None, substeps: int | str = "auto",
                 implicit: ImplicitParams = ImplicitParams(), obstacles=(),
                 rest_speed: float | None = None, device: str | None = None,
                 precision: str = "float64"):
        if str(backend) in ("warp", "Backend.WARP"):
            raise SceneError("backend = 'warp' is not distributed over MPI ranks: use "
                             "backend = 'numba' under mpiexec")
        self.comm = world() if comm is None else comm
        rank, size = self.comm.Get_rank(), self.comm.Get_size()
        self.rank, self.size = rank, size
        self.lean = self.comm.allreduce(int(model is None)) > 0
        """Rank 0 alone holds the global Model (the other ranks got ``model=None``): it builds
        every rank's part and sends it (:meth:`_distribute`)."""
        if self.lean and rank == 0 and model is None:
            raise ValueError("rank 0 must hold the global model (other ranks may pass None)")
        self.model = model
        """The global Model (``None`` on ranks other than 0 when :attr:`lean`)."""
        self.dt = float(dt)
        self.halo_bytes = 0
        """Bytes this rank sent to other ranks so far (ghost exchanges)."""
        self.comm_seconds = 0.0
        """Wall time this rank spent in the exchange and the status agreement [s]."""
        self.stability = None
        self.info = info = on_root(self.comm, lambda: body_info(model, runaway_distance))
        on_root(self.comm, lambda: start_checks(model, state, ground, obstacles),  # rank 0:
                share=False)  # the global start, as serially; a refusal raised on every rank
        self.center, self.runaway_distance = info.center, info.runaway_distance
        self.provot, self.ground, self.implicit = provot, ground, implicit
        if info.physical:  # the physical path: distributed/fem.py
            self._init_physical(model, state, owner, partition, integrator, provot, backend,
                                threads, substeps)
            self._pack_obstacles(ground, obstacles, rest_speed)
            return
        if substeps == "auto":  # as the serial Simulator counts them, on the global model
            symplectic = Integrator(integrator) is Integrator.SYMPLECTIC and check_stability
            substeps = on_root(self.comm, lambda: springs_auto_substeps(model, self.dt)[0]
                               if symplectic else 1)
        self.substeps = int(substeps)
        if self.substeps < 1:
            raise SceneError(f"substeps must be an integer >= 1, got {substeps}")
        self.integrator = Integrator(integrator)
        self.dt_step = self.dt / self.substeps
        n = info.n
        threads = self._node_threads(threads)  # default: the node's cores among its ranks
        self.replicated = replicated_reason(self.integrator, provot)
        if self.replicated is None and size > n:
            self.replicated = f"more ranks ({size}) than points ({n})"
        if self.replicated and self.lean:  # every rank needs the whole body
            model = self.model = self.comm.bcast(model, root=0)
            state = self.comm.bcast(state, root=0)
        self._set_owner(owner, lambda: partition_points(
            model.point_x0, model.spring_ij, 1 if self.replicated else size,
            method=partition))
        common = dict(dt=self.dt_step, integrator=self.integrator, provot=provot, ground=ground,
                      backend=backend, threads=int(threads), check_stability=False,
                      substeps=1, implicit=implicit, obstacles=obstacles,
                      rest_speed=rest_speed, runaway_distance=self.runaway_distance)
        if self.replicated:
            # every rank steps the whole body: the serial Simulator itself
            common.update(dt=self.dt, substeps=self.substeps)
            if state is None:
                state = model.state()
            self.global_start = state
            self.step, self.t = int(state.step), float(state.t)
            self.part = LocalPart(model, np.zeros(n, dtype=np.int32), rank, None)
            self.local = Simulator(model, state=state.copy(), **common)
        else:
            self.depth = depth = halo_depth(self.integrator, provot)
            graph = []

            def build(r):  # the spring graph built once, where the model is
                if not graph:
                    graph.append(point_graph(n, model.spring_ij))
                return LocalPart(model, self.owner, r, depth, graph=graph[0])

            self.part, local_state = self._distribute(build, model, state)
            self.local = Simulator(self.part.model, state=local_state, **common)
            self.local.center[:] = self.center  # runaway bound about the *body's* centre
            self._setup_exchange()
        self.local._started = True  # (no per-rank start check: a rank alone would raise it)
        self.split_implicit = not self.replicated and self.integrator is Integrator.IMPLICIT
        """The implicit integrator split among the ranks (:mod:`.implicit`)."""
        if self.split_implicit:
            self._rest_thin, self._collapse_check = on_root(
                self.comm, lambda: _rest_thinness(model.point_x0))
        self.state = self.local.state
        """This rank's local :class:`~jellysim.state.State` (owned points and ghosts)."""
        if check_stability and rank == 0:
            self.check_stability()

    # -- setup ------------------------------------------------------------------------------
    def _node_threads(self, asked=None):
        """The threads per rank (collective): ``asked``, or the node's cores divided among its
        ranks.  Sets :attr:`oversubscribed` (a message, or None) where ``asked`` threads on
        every rank of a node exceed its cores (HPC trial: ``-n 2 --threads 2`` on 2 cores ran
        4 busy threads on 2 cores, each waiting on the others, and said nothing)."""
        import os

        import numba
        from mpi4py import MPI

        node = self.comm.Split_type(MPI.COMM_TYPE_SHARED)
        ranks, pool = node.Get_size(), int(numba.config.NUMBA_NUM_THREADS)
        node.Free()
        cores = os.cpu_count() or 1
        if ranks > cores:  # (re-trial: -n 3 on 2 cores ran three busy ranks, unsaid)
            self.oversubscribed = (
                f"{ranks} ranks on a node of {cores} cores: more busy processes than cores, "
                f"which slows every rank; run at most mpiexec -n {cores} per node")
        if asked is None:
            return max(1, pool // ranks)
        runs = min(int(asked), pool)  # (more is capped, with a warning, by the Simulator)
        mine = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else cores
        if ranks <= cores and runs > 1 and (runs * ranks > cores or runs > mine):
            self.oversubscribed = (
                f"{ranks} ranks x {runs} threads on a node of {cores} cores"
                + (f" ({mine} for this rank)" if mine < cores else "") + ": more busy threads "
                f"than cores, which slows every rank; use --threads "
                f"{max(1, min(cores // ranks, mine))} (or leave it out)")
        return int(asked)

    def _set_owner(self, owner, compute):
        """The owner rank of every point: on every rank, or (:attr:`lean`) on rank 0 only;
        ``self.counts``: owned points per rank, on every rank."""
        n, size = self.info.n, self.size

        def check():
            own = compute() if owner is None else owner
            own = np.asarray(own, dtype=np.int32)
            if own.shape != (n,) or own.min() < 0 or own.max() >= size:
                raise ValueError(f"owner must have shape ({n},) with values in [0, {size})")
            return own

        if self.lean:
            self.owner = on_root(self.comm, check, share=False)
        elif owner is None:  # computed once, on rank 0, so every rank has the same
            self.owner = on_root(self.comm, check)
        else:
            self.owner = check()
        self.counts = on_root(self.comm, lambda: np.bincount(self.owner, minlength=size))

    def _distribute(self, build, model, state):
        """``(part, local state)`` of this rank.  ``build(r)``: rank r's
        :class:`~.local.LocalPart`.  Every rank builds its own from the global model, or
        (:attr:`lean`) rank 0 builds them one after the other and sends each to its rank, so
        the others never hold the global arrays.  Sets :attr:`global_start` (rank 0 only when
        lean), :attr:`step`, :attr:`t`."""

        def cut(part, st):
            g = part.glob
            return State(x=st.x[g].copy(), v=st.v[g].copy(), a=st.a[g].copy(), t=st.t,
                         step=st.step)

        mine = None
        if not self.lean:
            state = model.state() if state is None else state
            part = build(self.rank)
            mine = (part, cut(part, state))
        elif self.rank == 0:
            sent = 1
            try:
                state = model.state() if state is None else state
                for r in range(self.size):
                    part = build(r)
                    part.owner = None  # the global array stays here
                    if r == 0:
                        mine = (part, cut(part, state))
                    else:
                        self.comm.send((part, cut(part, state)), dest=r, tag=3)
                        sent = r + 1
                failure = None
            except Exception as exc:  # noqa: BLE001 (raised on every rank below)
                failure = exc
                for r in range(sent, self.size):
                    self.comm.send(None, dest=r, tag=3)
            self.comm.bcast(failure, root=0)
            if failure is not None:
                raise failure
        else:
            mine = self.comm.recv(source=0, tag=3)
            failure = self.comm.bcast(None, root=0)
            if failure is not None:
                raise failure
        self.global_start = state if (self.rank == 0 or not self.lean) else None
        """The global start state (rank 0 only when :attr:`lean`)."""
        self.step, self.t = int(mine[1].step), float(mine[1].t)
        return mine

    def _pack_obstacles(self, ground, obstacles, rest_speed):
        """Obstacles and the contact ground as the serial Simulator packs them."""

        obstacles = tuple(obstacles)
        try:
            if ground.enabled and GroundModel(ground.model) is GroundModel.CONTACT:
                obstacles = (ground_plane(ground),) + obstacles
            self._obstacle_kind, self._obstacle_data = pack_obstacles(obstacles)
        except ValueError as exc:
            raise SceneError(str(exc)) from None
        if rest_speed is None:
            rest_speed = 2.0 * float(np.linalg.norm(self.info.gravity)) * self.dt_step
        self.rest_speed = float(rest_speed)

    def _setup_exchange(self):
        needs = self.part.needs()
        requests = self.comm.alltoall([needs.get(r) for r in range(self.size)])
        for r, wanted in enumerate(requests):
            if wanted is not None and len(wanted):
                self.part.set_send(r, np.asarray(wanted, dtype=np.int64))
        self._sendbuf = {r: np.empty((len(i), 9)) for r, i in self.part.send.items()}
        self._recvbuf = {r: np.empty((len(i), 9)) for r, i in self.part.recv.items()}

    def check_stability(self):
        """The serial Simulator's stability estimate and warning, on the global model."""

        view = types.SimpleNamespace(model=self.model, integrator=self.integrator,
                                     dt_step=self.dt_step, dt=self.dt, implicit=self.implicit,
                                     provot=self.provot, substeps=self.substeps,
                                     stability=None)
        est = Simulator.check_stability(view)
        self.stability = est
        return est

    # -- stepping ---------------------------------------------------------------------------
    def advance(self, steps: int = 1) -> None:
        """Take ``steps`` time steps on every rank (a collective call).  Raises the same
        :class:`SimulationError` on every rank when any rank's points blow up."""
        if steps > 0:
            self._advance_scheduled(int(steps), self._advance_chunk)

    def _advance_chunk(self, steps: int) -> None:
        if steps <= 0:
            return
        done, status = 0, STATUS_OK
        if self.physical:
            before = self._thinness() if self._collapse_check else None
            done, status = self._advance_physical(int(steps))
        elif self.split_implicit:
            before = self._thinness() if self._collapse_check else None
            done, status = self._advance_implicit(int(steps))
        elif self.replicated:
            try:
                self.local.advance(int(steps))
                done = int(steps)
            except SimulationError as exc:
                done = self.local.state.step - self.step
                status = exc.status
        else:
            for _ in range(int(steps)):
                for _ in range(self.substeps):
                    status = self._substep()
                    if status != STATUS_OK:
                        break
                done += 1
                if status != STATUS_OK:
                    break
        self.t, self.step = clock(self.t, self.step, self.dt, done), self.step + done
        self.state.step, self.state.t = self.step, self.t
        if status != STATUS_OK:
            self._raise(status)
        if self.physical or self.split_implicit:
            self._check_collapse(before, done)
        if self.split_implicit:
            with warnings.catch_warnings():
                if self.rank != 0:
                    warnings.simplefilter("ignore")
                self.local._check_solves()

    def _advance_implicit(self, steps):
        """:meth:`Simulator._advance_implicit` with the distributed solve (:mod:`.implicit`)."""
        from .implicit import implicit_steps_distributed

        loc, s, sub = self.local, self.state, self.substeps
        bdf2 = loc._implicit_opts.bdf2
        changed = bdf2 and loc._last is not None and not (
            np.array_equal(loc._last[0], s.x) and np.array_equal(loc._last[1], s.v))
        flag = np.array([1 if changed else 0], dtype=np.int8)
        self.comm.Allreduce(_mpi_in_place(), flag, op=_mpi_max())
        if flag[0]:
            loc._fresh[:] = 1  # the state was changed from outside: restart the history
        import numba

        previous = numba.get_num_threads()
        numba.set_num_threads(max(1, min(loc.threads, numba.config.NUMBA_NUM_THREADS)))
        try:
            done, status, iters, worst = implicit_steps_distributed(self, steps * sub,
                                                                    self.dt_step)
        finally:
            numba.set_num_threads(previous)
        if bdf2:
            loc._last = (s.x.copy(), s.v.copy())
        loc.cg_iterations += int(iters)
        loc._last_worst = float(worst)
        loc.cg_worst_residual = max(loc.cg_worst_residual, float(worst))
        return (done + sub - 1) // sub, status

    def _substep(self) -> int:
        try:  # (not advance(): its check of a state moved by hand between calls would see
            # the ghosts the exchange writes, a neighbour's blow-up on this rank alone, and
            # raise here only, leaving the other ranks in Allreduce: a hang, the HPC trial)
            self.local._advance_scheduled(1)
            status = STATUS_OK
        except SimulationError:
            status = self.part.owned_status(self.local.state, self.center,
                                            self.runaway_distance**2)
        return self._agree(status)

    def _agree(self, status) -> int:
        """The run status agreed by all ranks (one ``Allreduce``); the ghost exchange when
        it is OK."""
        from mpi4py import MPI
        import time

        t0 = time.perf_counter()
        flags = np.array([status == STATUS_NONFINITE, status == STATUS_RUNAWAY], dtype=np.int8)
        self.comm.Allreduce(MPI.IN_PLACE, flags, op=MPI.MAX)
        status = combine_status(flags)
        if status == STATUS_OK:
            self._exchange()
        self.comm_seconds += time.perf_counter() - t0
        return status

    def _exchange(self):
        from mpi4py import MPI

        s, part = self.state, self.part
        reqs = [self.comm.Irecv(buf, source=r, tag=7) for r, buf in self._recvbuf.items()]
        for r, idx in part.send.items():
            buf = self._sendbuf[r]
            part.pack(s, idx, buf)
            reqs.append(self.comm.Isend(buf, dest=r, tag=7))
            self.halo_bytes += buf.nbytes
        MPI.Request.Waitall(reqs)
        for r, idx in part.recv.items():
            part.unpack(s, idx, self._recvbuf[r])

    def _raise(self, status):
        """The serial run's :class:`SimulationError` (its message built on rank 0, which
        holds the global model), raised on every rank."""

        view = types.SimpleNamespace(
            model=self.model, state=types.SimpleNamespace(step=self.step, t=self.t),
            runaway_distance=self.runaway_distance, stability=self.stability,
            integrator=self.integrator, dt_step=self.dt_step, implicit=self.implicit,
            physical=self.physical, substeps=self.substeps,
            MAX_SUBSTEP_DOUBLINGS=self.MAX_SUBSTEP_DOUBLINGS,
            travelled=getattr(self, "travelled", False))
        raise_agreed(self.comm, lambda: Simulator._raise(view, status))

    def energy(self):
        """Not under MPI: each rank holds part of the body (the serial method mixed the
        global model with this rank's local state: a traceback, session 24's trial)."""
        raise SceneError(_WHOLE_BODY.format("energy()"))

    def volume_ratios(self):
        """Not under MPI (see :meth:`energy`); ``min_tet_volume_ratio`` is agreed."""
        raise SceneError(_WHOLE_BODY.format("volume_ratios()"))

    # -- output ---------------------------------------------------------------------------
    def gather(self, root: int = 0) -> State | None:
        """The global state (x, v, a of every point, global order) on ``root``; ``None`` on
        the other ranks.  A collective call."""
        s, part = self.state, self.part
        if self.replicated:
            if self.rank != root:
                return None
            return State(s.x.copy(), s.v.copy(), s.a.copy(), self.t, self.step)
        mine = np.empty((part.owned_local.size, 9))
        part.pack(s, part.owned_local, mine)
        counts = self.counts * 9
        if self.rank == root:
            flat = np.empty(int(counts.sum()))
            displs = np.concatenate([[0], np.cumsum(counts)[:-1]])
            self.comm.Gatherv(mine.ravel(), [flat, counts, displs, _mpi_double()], root=root)
            order = np.argsort(self.owner, kind="stable")  # rank-major, global order within
            allv = np.empty((self.info.n, 9))
            allv[order] = flat.reshape(-1, 9)
            return State(allv[:, 0:3].copy(), allv[:, 3:6].copy(), allv[:, 6:9].copy(),
                         self.t, self.step)
        self.comm.Gatherv(mine.ravel(), None, root=root)
        return None


def _mpi_in_place():
    from mpi4py import MPI

    return MPI.IN_PLACE


def _mpi_max():
    from mpi4py import MPI

    return MPI.MAX


def _mpi_double():
    from mpi4py import MPI

    return MPI.DOUBLE

