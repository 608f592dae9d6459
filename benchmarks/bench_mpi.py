"""MPI: halo sizes of the two partitions, and steps/s on 1..P ranks (docs/mpi.md).

Body: the bench_step recipe, N uniform points in a 1 m cube resting on the ground, radius
springs r = 0.3 (600 / N)^(1/3) (about 33 springs per point), k = 2 N/m, delta = 0.8 kg/s,
1141 kg/m^3; the report's integrator with one Jacobi Provot pass over the springs and the
report's ground (one ghost layer), dt = 1 ms.

Halo sizes (no MPI needed)::

    python -m benchmarks.bench_mpi halo --points 10000

Throughput (rank 0 prints one JSON line; run it for P = 1, 2, ... with the same N for strong
scaling, N proportional to P for weak scaling)::

    mpiexec -n 2 python -m benchmarks.bench_mpi step --points 100000 --threads 1 [--lean]

(``--lean``: the model on rank 0 only, which sends each rank its part, as ``mpiexec jellysim
run`` does; default: every rank holds the global model.)

Bitwise equality with the serial Simulator on rank 0 (one JSON line)::

    mpiexec -n 3 python -m benchmarks.bench_mpi check --points 100000 --steps 20

The physical (FEM) path: a gelatin box (``[material] preset = "gelatin"``, grid of about N
points, Stable Neo-Hookean tets, symplectic substeps) resting on the contact ground; frames of
1/60 s, each many substeps (rank 0 prints one JSON line; ``--check`` also runs the serial
Simulator on rank 0 and compares bitwise)::

    mpiexec -n 2 python -m benchmarks.bench_mpi fem --points 20000 --frames 2

The implicit integrator (springs, backward Euler, CG with distributed dot products)::

    mpiexec -n 2 python -m benchmarks.bench_mpi implicit --points 20000 --steps 5

``step`` reports steps/s (median of the timed windows, each window ``--steps`` steps), per rank the
seconds spent in the ghost exchange and the status agreement vs in the local step, ghost
points and halo bytes sent per step, and the load average (other processes share the cores).
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import time

import numpy as np


def make_model(n: int, seed: int = 1):
    from jellysim import Body, finalize
    from jellysim.geometry import box_field, radius_springs

    pts = box_field(n, [0, 0, 0], [1, 1, 1], seed=seed)
    r = 0.3 * (600 / n) ** (1 / 3)
    body = Body(points=pts, springs=radius_springs(pts, r), volume=1.0)
    return finalize(body, stiffness=2.0, density=1141.0, damping=0.8)


def halo(args) -> None:
    from jellysim.distributed import halo_stats

    m = make_model(args.points)
    rows = []
    for parts in (2, 3, 4, 8, 16):
        for method in ("morton", "metis"):
            for depth in (1, 2):
                st = halo_stats(m.point_x0, m.spring_ij, parts, method=method, depth=depth)
                rows.append({k: st[k] for k in ("method", "parts", "depth", "ghosts_total",
                                                "cut_springs")}
                            | {"ghosts_max": max(st["ghosts"]),
                               "ghost_fraction": st["ghosts_total"] / st["points"]})
    print(json.dumps({"bench": "mpi_halo", "points": m.point_count,
                      "springs": m.spring_count, "rows": rows}))


def step(args) -> None:
    from mpi4py import MPI

    from jellysim.distributed import DistributedSimulator
    from jellysim.params import GroundParams, ProvotParams

    comm = MPI.COMM_WORLD
    rank, size = comm.Get_rank(), comm.Get_size()
    t0 = time.perf_counter()
    if args.points >= 500_000 and not args.lean:
        # every rank builds the same (seeded) body: broadcasting a pickle of millions of
        # springs would hold two more copies of the model in memory at once
        model = make_model(args.points)
    else:
        model = make_model(args.points) if rank == 0 else None
        if not args.lean:  # every rank holds the global model (else: rank 0 sends the parts)
            model = comm.bcast(model, root=0)
    build_s = time.perf_counter() - t0
    sim = DistributedSimulator(model, comm=comm, dt=1e-3, integrator="paper",
                               provot=ProvotParams(loops=1, tau=0.001),
                               ground=GroundParams(), threads=args.threads,
                               check_stability=False, partition=args.partition)
    setup_s = time.perf_counter() - t0 - build_s
    med, ranks = _timed(comm, sim, args, args.steps)
    if rank == 0:
        print(json.dumps({"bench": "mpi_step", "ranks": size, "threads_per_rank": args.threads,
                          "lean": sim.lean, "setup_s": setup_s,
                          "points": model.point_count, "springs": model.spring_count,
                          "partition": args.partition, "steps_per_window": args.steps,
                          "steps_per_s": args.steps / med, "build_s": build_s,
                          "per_rank": ranks, "loadavg_1min": os.getloadavg()[0]}))


def check(args) -> None:
    """Distributed run vs the serial Simulator on rank 0: bitwise equal positions?"""
    from mpi4py import MPI

    from jellysim.distributed import DistributedSimulator
    from jellysim.params import GroundParams, ProvotParams
    from jellysim.simulator import Simulator

    comm = MPI.COMM_WORLD
    model = comm.bcast(make_model(args.points) if comm.Get_rank() == 0 else None, root=0)
    kw = dict(dt=1e-3, integrator=args.integrator, provot=ProvotParams(loops=args.loops,
              tau=0.001), ground=GroundParams(), check_stability=False)
    sim = DistributedSimulator(model, comm=comm, threads=1, partition=args.partition, **kw)
    sim.advance(args.steps)
    state = sim.gather(0)
    if comm.Get_rank() == 0:
        serial = Simulator(model, threads=1, **kw)
        serial.advance(args.steps)
        print(json.dumps({"bench": "mpi_check", "ranks": comm.Get_size(),
                          "points": model.point_count, "steps": args.steps,
                          "integrator": args.integrator, "provot_loops": args.loops,
                          "partition": args.partition,
                          "x_bitwise_equal": bool(np.array_equal(state.x, serial.state.x)),
                          "v_bitwise_equal": bool(np.array_equal(state.v, serial.state.v)),
                          "moved_m": float(np.abs(state.x - model.point_x0).max())}))


def gelatin_scene(n: int):
    from jellysim.scene import Scene

    side = round(n ** (1 / 3)) - 1  # cells per edge of the grid, spacing 1 cm
    return Scene.from_text(f"""
[material]
preset = "gelatin"
[body]
type = "box"
points = {side ** 3}
distribution = "grid"
lower = [0.0, 0.0, 0.0]
upper = [{side / 100}, {side / 100}, {side / 100}]
[springs]
connect = "radius"
radius = 0.018
[integrator]
steps = 1
""", name="bench_mpi fem")


def _timed(comm, sim, args, count):
    sim.advance(1)  # warm up (compiles / loads the kernels)
    windows, comm_s = [], []
    b0 = sim.halo_bytes
    for _ in range(args.repeats):
        comm.Barrier()
        c0, t = sim.comm_seconds, time.perf_counter()
        sim.advance(count)
        windows.append(time.perf_counter() - t)
        comm_s.append(sim.comm_seconds - c0)
    mine = {"comm_s": float(np.sum(comm_s)), "total_s": float(np.sum(windows)),
            "ghosts": int((~sim.part.owned).sum()), "owned": int(sim.part.owned.sum()),
            "halo_bytes_per_step": (sim.halo_bytes - b0) / (args.repeats * count),
            "finite": bool(np.all(np.isfinite(sim.state.x))),
            "max_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}
    return float(np.median(windows)), comm.gather(mine, root=0)


def fem(args) -> None:
    """The physical path: frames/s and substeps/s on P ranks (1 thread each)."""
    from mpi4py import MPI

    from jellysim.distributed import DistributedSimulator

    comm = MPI.COMM_WORLD
    rank, size = comm.Get_rank(), comm.Get_size()
    scene = gelatin_scene(args.points)
    model = scene.build_model() if rank == 0 else None  # rank 0 only, as jellysim run does
    kw = comm.bcast(scene.simulator_kwargs(model) if rank == 0 else None, root=0)
    kw["threads"] = 1
    t0 = time.perf_counter()
    sim = DistributedSimulator(model, comm=comm, partition=args.partition, **kw)
    setup_s = time.perf_counter() - t0
    med, ranks = _timed(comm, sim, args, args.frames)
    ok = None
    if args.check:
        state = sim.gather(0)
        if rank == 0:
            from jellysim.simulator import Simulator

            serial = Simulator(model, **kw)
            serial.advance(1 + args.repeats * args.frames)
            ok = bool(np.array_equal(state.x, serial.state.x)
                      and np.array_equal(state.v, serial.state.v))
    if rank == 0:
        print(json.dumps({"bench": "mpi_fem", "ranks": size, "threads_per_rank": 1,
                          "points": model.point_count, "tets": model.fem.tet_count,
                          "setup_s": setup_s,
                          "substeps_per_frame": sim.substeps, "partition": args.partition,
                          "frames_per_window": args.frames, "frames_per_s": args.frames / med,
                          "substeps_per_s": args.frames * sim.substeps / med,
                          "bitwise_equal_to_serial": ok, "per_rank": ranks,
                          "loadavg_1min": os.getloadavg()[0]}))


def implicit(args) -> None:
    """The implicit integrator (springs, backward Euler, contact ground): the bench body released
    stretched 20 % upwards; steps/s on P ranks, CG iterations."""
    from mpi4py import MPI

    from jellysim.distributed import DistributedSimulator
    from jellysim.params import GroundParams, ImplicitParams

    comm = MPI.COMM_WORLD
    rank, size = comm.Get_rank(), comm.Get_size()
    model = comm.bcast(make_model(args.points) if rank == 0 else None, root=0)
    start = model.state()  # released stretched 20 % upwards: it vibrates, CG has work
    start.x[:, 1] = 1.2 * start.x[:, 1]
    sim = DistributedSimulator(model, comm=comm, dt=1e-2, integrator="implicit",
                               ground=GroundParams(model="contact"), threads=1, state=start,
                               implicit=ImplicitParams(cg_tolerance=1e-4),
                               check_stability=False, partition=args.partition)
    med, ranks = _timed(comm, sim, args, args.steps)
    if rank == 0:
        print(json.dumps({"bench": "mpi_implicit", "ranks": size, "threads_per_rank": 1,
                          "points": model.point_count, "springs": model.spring_count,
                          "partition": args.partition, "steps_per_window": args.steps,
                          "steps_per_s": args.steps / med,
                          "cg_iterations": sim.local.cg_iterations, "per_rank": ranks,
                          "loadavg_1min": os.getloadavg()[0]}))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="what", required=True)
    h = sub.add_parser("halo")
    h.add_argument("--points", type=int, default=10000)
    s = sub.add_parser("step")
    s.add_argument("--points", type=int, default=100000)
    s.add_argument("--steps", type=int, default=20)
    s.add_argument("--repeats", type=int, default=5)
    s.add_argument("--threads", type=int, default=1)
    s.add_argument("--partition", default="morton", choices=["morton", "metis"])
    s.add_argument("--lean", action="store_true", help="the model on rank 0 only")
    c = sub.add_parser("check")
    c.add_argument("--points", type=int, default=100000)
    c.add_argument("--steps", type=int, default=20)
    c.add_argument("--loops", type=int, default=2)
    c.add_argument("--integrator", default="paper", choices=["paper", "symplectic"])
    c.add_argument("--partition", default="morton", choices=["morton", "metis"])
    f = sub.add_parser("fem")
    f.add_argument("--points", type=int, default=20000)
    f.add_argument("--frames", type=int, default=2)
    f.add_argument("--repeats", type=int, default=3)
    f.add_argument("--partition", default="morton", choices=["morton", "metis"])
    f.add_argument("--check", action="store_true")
    i = sub.add_parser("implicit")
    i.add_argument("--points", type=int, default=20000)
    i.add_argument("--steps", type=int, default=5)
    i.add_argument("--repeats", type=int, default=3)
    i.add_argument("--partition", default="morton", choices=["morton", "metis"])
    args = ap.parse_args()
    {"halo": halo, "step": step, "check": check, "fem": fem,
     "implicit": implicit}[args.what](args)


if __name__ == "__main__":
    main()
