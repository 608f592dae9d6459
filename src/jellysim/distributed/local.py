"""One rank's share of a body: its owned points, its ghost layers, and a local Model.

The local Model keeps the *global relative order* of points and springs (local index =
rank of the global index among the local ones), so every owned point's springs sit in its
first- and second-point lists in the same order as in the global Model, and the kernels sum
its forces and Provot corrections in exactly the serial order: the owned points come out
bitwise equal to a serial run.  Points of the outer ghost layers get incomplete sums; they
are overwritten by their owners' values after each step (:meth:`LocalPart.pack` /
:meth:`LocalPart.unpack`).

How deep the ghost layers must be (:func:`halo_depth`): a step of the explicit integrators
reads neighbours in a fixed number of passes (forces, each Jacobi Provot loop); with that many
ghost layers a rank computes its owned points exactly from ghosts that were right at the start
of the step, so one exchange per (sub)step suffices.  Everything else in a step (integration,
ground, obstacle contact, the velocity update, the checks) is per point.
"""
from __future__ import annotations

import numpy as np

from ..kernels import STATUS_NONFINITE, STATUS_OK, STATUS_RUNAWAY
from ..params import Integrator, ProvotOrder, ProvotPairs
from .partition import halo_layers, point_graph
from ..body import Body
from ..model import finalize

__all__ = ["LocalPart", "halo_depth", "replicated_reason"]


def replicated_reason(integrator, provot) -> str | None:
    """Why a configuration cannot be split among ranks (then every rank runs the whole
    body: results stay equal to serial, without speed-up), or ``None`` when it can."""
    if provot.enabled and provot.loops > 0:
        if ProvotPairs(provot.pairs) is ProvotPairs.ALL:
            return "provot pairs = 'all' couples every point with every other"
        if ProvotOrder(provot.order) is ProvotOrder.GAUSS_SEIDEL:
            return "provot order = 'gauss-seidel' is sequential over the whole spring list"
        if provot.tolerance > 0:
            return "provot tolerance > 0 stops the loops on a body-wide maximum"
        return ("provot order = 'jacobi' subtracts each pass's body-wide mass-weighted mean "
                "move (it conserves momentum): a sum over every point")
    return None


def halo_depth(integrator, provot) -> int:
    """Neighbour-reading passes in one explicit kernel step = ghost layers needed.

    ``paper``: x and v are advanced first (per point), then forces and the first Jacobi
    Provot loop share one pass, then ``loops - 1`` more passes.  ``symplectic``: the forces
    at the start positions, then ``loops`` Provot passes."""
    loops = int(provot.loops) if provot.enabled else 0
    if Integrator(integrator) is Integrator.PAPER:
        return max(1, loops)
    return 1 + loops


class LocalPart:
    """Rank ``rank``'s points: owned ones (``owner == rank``) and ``depth`` ghost layers.

    Attributes: ``glob`` (global index of each local point, sorted), ``owned`` (bool mask over
    local points), ``model`` (the local :class:`~jellysim.model.Model`), ``recv`` (owner rank
    -> local indices of the ghosts it owns, in global order) and ``send`` (rank -> local
    indices of owned points that rank holds as ghosts, in global order; set by
    :meth:`set_send`).  ``depth = None``: every point is local (replicated run).
    """

    def __init__(self, model, owner: np.ndarray, rank: int, depth: int | None, *,
                 graph=None):
        n = model.point_count
        self.rank = int(rank)
        self.owner = owner
        if depth is None:
            glob = np.arange(n, dtype=np.int64)
        else:
            xadj, adjncy = point_graph(n, model.spring_ij) if graph is None else graph
            layers = halo_layers(owner, rank, xadj, adjncy, depth)
            glob = np.sort(np.concatenate([np.flatnonzero(owner == rank)] + layers))
        self.glob = glob
        self.owned = owner[glob] == rank
        self.owned_local = np.flatnonzero(self.owned)
        if depth is None:
            self.model = model
        else:
            local_of = np.full(n, -1, dtype=np.int64)
            local_of[glob] = np.arange(glob.size)
            ij = model.spring_ij
            keep = (local_of[ij[:, 0]] >= 0) & (local_of[ij[:, 1]] >= 0)
            body = Body(points=model.point_x0[glob], springs=local_of[ij[keep]],
                        rest_length=model.spring_rest_length[keep],
                        stiffness=model.spring_stiffness[keep], masses=model.point_mass[glob],
                        meta={"distributed_rank": self.rank})
            self.model = finalize(body, damping=model.damping, gravity=model.gravity)
        ghost = ~self.owned
        self.recv: dict[int, np.ndarray] = {}
        if depth is not None:
            gl = np.flatnonzero(ghost)
            for r in np.unique(owner[glob[gl]]):
                self.recv[int(r)] = gl[owner[glob[gl]] == r]
        self.send: dict[int, np.ndarray] = {}

    def needs(self) -> dict[int, np.ndarray]:
        """Owner rank -> global indices of the ghosts this rank needs from it."""
        return {r: self.glob[idx] for r, idx in self.recv.items()}

    def set_send(self, rank: int, global_indices: np.ndarray) -> None:
        """Record that ``rank`` needs these owned points (global indices) after each step."""
        local = np.searchsorted(self.glob, global_indices)
        if not (np.all(self.glob[local] == global_indices) and np.all(self.owned[local])):
            raise ValueError(f"rank {rank} asked rank {self.rank} for points it does not own")
        self.send[int(rank)] = local

    @staticmethod
    def pack(state, idx: np.ndarray, out: np.ndarray) -> None:
        """x, v, a of local points ``idx`` into ``out`` [m, m/s, m/s^2], shape (len, 9)."""
        np.take(state.x, idx, axis=0, out=out[:, 0:3])
        np.take(state.v, idx, axis=0, out=out[:, 3:6])
        np.take(state.a, idx, axis=0, out=out[:, 6:9])

    @staticmethod
    def unpack(state, idx: np.ndarray, buf: np.ndarray) -> None:
        state.x[idx] = buf[:, 0:3]
        state.v[idx] = buf[:, 3:6]
        state.a[idx] = buf[:, 6:9]

    def owned_status(self, state, center, bound2) -> int:
        """The per-point check of :func:`~jellysim.kernels.numba_backend.finish_step` over the
        owned points only (a ghost's incomplete values must not stop a run)."""
        o = self.owned_local
        s = state.x[o].sum(axis=1) + state.v[o].sum(axis=1) + state.a[o].sum(axis=1)
        if not np.all(np.isfinite(s)):
            return STATUS_NONFINITE
        r = state.x[o] - center
        if np.any(np.einsum("ij,ij->i", r, r) > bound2):
            return STATUS_RUNAWAY
        return STATUS_OK


def combine_status(flags) -> int:
    """Status from body-wide (non-finite?, runaway?) flags, non-finite first as serially."""
    if flags[0]:
        return STATUS_NONFINITE
    if flags[1]:
        return STATUS_RUNAWAY
    return STATUS_OK
