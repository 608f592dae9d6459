"""Test helper, run under ``mpiexec -n P``: the implicit integrator split among the ranks
(:class:`DistributedSimulator`) vs the serial :class:`Simulator` on rank 0, on a stiff spring
box released stretched and twisted in free space (it vibrates; every step needs a real CG
solve).  Rank 0 prints one JSON line.  Arguments: scheme (theta / bdf2), CG tolerance, and
``lean`` (the model on rank 0 only) or ``full`` (on every rank)."""
import json
import sys

import numpy as np
from mpi4py import MPI

from jellysim import Body, finalize
from jellysim.distributed import DistributedSimulator
from jellysim.geometry import box_field, radius_springs
from jellysim.params import ImplicitParams
from jellysim.simulator import Simulator

scheme, tol, lean = sys.argv[1], float(sys.argv[2]), sys.argv[3] == "lean"
comm = MPI.COMM_WORLD
rank = comm.Get_rank()
model = None
if rank == 0 or not lean:
    pts = box_field(500, [0, 0, 0], [0.8, 0.8, 0.8], seed=3)
    model = finalize(Body(points=pts, springs=radius_springs(pts, 0.2), volume=0.512),
                     stiffness=3000.0, density=100.0, damping=0.3)
start = None
if model is not None:
    start = model.state()
    c = model.point_x0.mean(axis=0)
    r = model.point_x0 - c
    ang = 0.6 * r[:, 1]  # twist about y, stretch along y
    start.x[:] = c + np.stack([r[:, 0] * np.cos(ang) - r[:, 2] * np.sin(ang), 1.2 * r[:, 1],
                               r[:, 0] * np.sin(ang) + r[:, 2] * np.cos(ang)], axis=1)
kw = dict(dt=0.01, integrator="implicit", check_stability=False,
          implicit=ImplicitParams(scheme=scheme, cg_tolerance=tol, max_iterations=2000))
sim = DistributedSimulator(model, comm=comm, threads=1, state=start, **kw)
sim.advance(25)
got = sim.gather(0)
# lean: no rank but 0 holds a global array (model, start state, owner of every point)
held = comm.gather(any(a is not None for a in (sim.model, sim.global_start, sim.owner))
                   or sim.part.model.point_count >= 500, root=0)
if rank == 0:
    serial = Simulator(model, threads=1, state=start.copy(), **kw)
    serial.advance(25)
    x = serial.state.x
    travel = float(np.abs(x - start.x).max())
    print(json.dumps({"ranks": comm.Get_size(), "lean": sim.lean, "travel": travel,
                      "rel_error": float(np.abs(got.x - x).max()) / travel,
                      "v_rel_error": float(np.abs(got.v - serial.state.v).max()
                                           / np.abs(serial.state.v).max()),
                      "cg_iterations": sim.local.cg_iterations,
                      "serial_cg_iterations": serial.cg_iterations,
                      "ghosts": int((~sim.part.owned).sum()), "owned": int(sim.part.owned.sum()),
                      "owned_total": int(sim.counts.sum()),
                      "others_hold_global": any(held[1:])}))
