"""Benchmark: the 10 cm gelatin cube at 20^3 points, implicit integrator, dt = 1/60 s.

Prints JSON: build time, simulated seconds, wall seconds per simulated second (median of
``--repeats`` runs), CG iterations per step, realtime factor.  Run from the repository root:

    PYTHONPATH=src python benchmarks/bench_physical.py [--points-per-side 20] [--seconds 5]
        [--repeats 3] [--threads 1] [--substeps 1] [--youngs-modulus 1e4] [--scheme theta|bdf2]

The cube starts 2 cm above the plate: it falls, lands, wobbles and settles.  One thread is the
default (and what the Simulator picks for 8000 points): on a shared 2-core machine a second
numba thread that has to wait for a busy core makes every parallel region slower.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time

import numpy as np


def build(points_per_side: int, youngs_modulus: float):
    from jellysim.body import Body
    from jellysim.geometry.connect import radius_springs
    from jellysim.geometry.lattice import grid_point_volumes
    from jellysim.model import finalize
    from jellysim.physics.material import calibrate_springs
    from jellysim.presets import GELATIN_DENSITY

    size, drop = 0.1, 0.02
    axis = np.linspace(0.0, size, points_per_side)
    pts = np.stack(np.meshgrid(axis, axis + drop, axis, indexing="ij"), -1).reshape(-1, 3)
    h = size / (points_per_side - 1)
    body = Body(points=pts, springs=radius_springs(pts, 1.8 * h), volume=size**3,
                meta={"builder": "grid"})
    pv = grid_point_volumes(pts)
    body.stiffness = calibrate_springs(body, youngs_modulus, point_volume=pv)
    body.masses = GELATIN_DENSITY * pv
    return finalize(body, gravity=(0.0, -9.8, 0.0))


def run_once(model, seconds: float, threads: int, substeps: int = 1, scheme: str = "theta"):
    from jellysim.params import GroundModel, GroundParams, ImplicitParams
    from jellysim.simulator import Simulator

    ground = GroundParams(model=GroundModel.CONTACT, restitution=0.3, friction=0.6)
    sim = Simulator(model, dt=1 / 60, integrator="implicit", ground=ground, threads=threads,
                    substeps=substeps, implicit=ImplicitParams(scheme=scheme))
    sim.advance(1)  # compile / warm caches outside the timing
    steps = int(round(seconds * 60))
    t0 = time.perf_counter()
    sim.advance(steps)
    wall = time.perf_counter() - t0
    top = float(sim.state.x[:, 1].max())
    return wall, sim.cg_iterations / max(sim.state.step, 1), top


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points-per-side", type=int, default=20)
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--substeps", type=int, default=1,
                    help="implicit steps per 1/60 s frame (4: livelier wobble)")
    ap.add_argument("--scheme", default="theta", choices=("theta", "bdf2"),
                    help="implicit scheme (theta = backward Euler)")
    ap.add_argument("--youngs-modulus", type=float, default=None,
                    help="[Pa], default: the gelatin preset's")
    args = ap.parse_args()
    if args.youngs_modulus is None:
        from jellysim.presets import GELATIN_YOUNGS_MODULUS

        args.youngs_modulus = GELATIN_YOUNGS_MODULUS
    t0 = time.perf_counter()
    model = build(args.points_per_side, args.youngs_modulus)
    build_s = time.perf_counter() - t0
    walls, iters, tops = [], [], []
    for _ in range(args.repeats):
        wall, it, top = run_once(model, args.seconds, args.threads, args.substeps,
                                 args.scheme)
        walls.append(wall)
        iters.append(it)
        tops.append(top)
    med = statistics.median(walls)
    print(json.dumps({
        "benchmark": "gelatin cube, implicit, dt=1/60",
        "points": model.particle_count, "springs": model.spring_count,
        "youngs_modulus_pa": args.youngs_modulus, "threads": args.threads,
        "substeps": args.substeps, "scheme": args.scheme,
        "build_s": round(build_s, 3), "simulated_s": args.seconds,
        "wall_s_runs": [round(w, 3) for w in walls], "wall_s_median": round(med, 3),
        "realtime_factor": round(args.seconds / med, 2),
        "cg_iterations_per_step": round(statistics.median(iters), 1),
        "final_top_m": round(statistics.median(tops), 5),
        "cpu": platform.processor() or platform.machine(), "cores": os.cpu_count(),
        "loadavg_1min": round(os.getloadavg()[0], 2),
    }, indent=2))


if __name__ == "__main__":
    main()
