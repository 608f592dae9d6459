"""Benchmark: the physical path (gelatin preset, FEM tets, symplectic substeps) at dt = 1/60 s.

Prints JSON: for each body size, the substeps the stability estimate picks, CPU time per
substep, the real-time factor (simulated seconds per wall second, median of ``--repeats``),
the wobble's energy kept per period, and a drop-survival table (6 cm ball, E = 5 and 10 kPa,
dropped 10 and 50 cm: final top height vs the same ball at rest, smallest tet volume ratio).
Run from the repository root:

    PYTHONPATH=src python benchmarks/bench_physical.py [--cells 10 21] [--seconds 1]
        [--repeats 3] [--threads 1] [--no-drops] [--implicit]
        [--drop-builders marching delaunay]

``--implicit`` adds the previous path (springs calibrated to E, implicit backward Euler at
dt = 1/60 s, one solve per frame) on the same grid for comparison.  One thread is the default:
the issue's target is the real-time factor of a 10,000-point body on one core (21^3 = 9261
grid points).
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def cube(cells: int, size: float = 0.1, lift: float = 0.02):
    from jellysim.body import Body
    from jellysim.geometry.connect import radius_springs
    from jellysim.geometry.lattice import grid_points, grid_tets

    pts = grid_points((cells + 1) ** 3, [0, lift, 0], [size, size + lift, size])
    return Body(points=pts, springs=radius_springs(pts, 1.8 * size / cells), volume=size**3,
                tets=grid_tets(pts), meta={"distribution": "grid"})


def run_fem(cells, seconds, threads):
    from jellysim.params import GroundModel, GroundParams
    from jellysim.physics.policy import physical_model
    from jellysim.presets import gelatin
    from jellysim.simulator import Simulator

    model = physical_model(cube(cells), gelatin())
    ground = GroundParams(model=GroundModel.CONTACT)
    sim = Simulator(model, dt=1 / 60, ground=ground, threads=threads)
    sim.advance(1)  # compile outside the timing
    frames = int(round(seconds * 60))
    w0, c0 = time.perf_counter(), time.process_time()
    sim.advance(frames)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    return {"points": model.point_count, "tets": model.fem.tet_count,
            "substeps": sim.substeps, "wall_s": wall,
            "cpu_ms_per_substep": 1e3 * cpu / (frames * sim.substeps),
            "top_m": float(sim.state.x[:, 1].max()),
            "min_tet_volume_ratio": sim.min_tet_volume_ratio}


def run_implicit(cells, seconds, threads):
    from jellysim.params import GroundModel, GroundParams, Material
    from jellysim.physics.policy import physical_model
    from jellysim.geometry.lattice import grid_point_volumes
    from jellysim.simulator import Simulator

    body = cube(cells)
    model = physical_model(body, Material(model="springs"),
                           point_volume=grid_point_volumes(body.points))
    sim = Simulator(model, dt=1 / 60, integrator="implicit", threads=threads,
                    ground=GroundParams(model=GroundModel.CONTACT))
    sim.advance(1)
    frames = int(round(seconds * 60))
    w0 = time.perf_counter()
    sim.advance(frames)
    return {"points": model.point_count, "wall_s": time.perf_counter() - w0,
            "cg_iterations_per_step": sim.cg_iterations / max(sim.state.step, 1)}


def wobble_energy_kept():
    sys.path.insert(0, str(ROOT / "tests"))
    import test_physical_path as T
    from jellysim.presets import gelatin

    u, sim = T._top_sway(gelatin(damping_ratio=0.0), seconds=2.0)
    f, _ = T._frequency_and_peaks(u)
    e = sim.energy
    periods = len(e) / 60 * f
    return {"frequency_hz": round(float(f), 3),
            "energy_kept_per_period": round(float((e[-30:].mean() / e[:30].mean())
                                                  ** (1 / periods)), 5)}


def drops(builders=("marching", "delaunay")):
    sys.path.insert(0, str(ROOT / "tests"))
    import test_physical_path as T
    from jellysim.presets import gelatin

    rows = []
    for connect in builders:
        rows += _drops(T, gelatin, T._ball(points=400, connect=connect), connect)
    return rows


def _drops(T, gelatin, body, connect):
    rows = []
    for E in (5e3, 1e4):
        mat = gelatin(youngs_modulus=E, damping_ratio=0.1, damping_frequency=8.0)
        _, _, rest_top = T._run_drop(body, mat, 0.0, 1.5)
        rest = float(rest_top[-10:].mean())
        for drop in (0.1, 0.5):
            sim, _, top = T._run_drop(body, mat, drop, 2.5)
            rows.append({"connect": connect, "points": sim.model.point_count,
                         "substeps": sim.substeps, "E_pa": E, "drop_m": drop,
                         "rest_top_m": round(rest, 5),
                         "final_top_m": round(float(top[-10:].mean()), 5),
                         "final_over_rest": round(float(top[-10:].mean()) / rest, 4),
                         "frame_min_J": round(sim.frame_min_j, 3),
                         "substep_min_J": round(sim.min_tet_volume_ratio, 3)})
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, nargs="+", default=[10, 21])
    ap.add_argument("--seconds", type=float, default=1.0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--no-drops", action="store_true")
    ap.add_argument("--drop-builders", nargs="+", default=["marching", "delaunay"],
                    choices=["marching", "delaunay", "tetgen"])
    ap.add_argument("--implicit", action="store_true")
    args = ap.parse_args()
    sizes = []
    for cells in args.cells:
        runs = [run_fem(cells, args.seconds, args.threads) for _ in range(args.repeats)]
        med = statistics.median(r["wall_s"] for r in runs)
        row = dict(runs[0], wall_s_runs=[round(r["wall_s"], 3) for r in runs],
                   realtime_factor=round(args.seconds / med, 3),
                   cpu_ms_per_substep=round(statistics.median(
                       r["cpu_ms_per_substep"] for r in runs), 4))
        row.pop("wall_s")
        if args.implicit:
            imp = [run_implicit(cells, args.seconds, args.threads) for _ in range(args.repeats)]
            row["implicit_springs_realtime_factor"] = round(
                args.seconds / statistics.median(r["wall_s"] for r in imp), 3)
            row["implicit_cg_iterations_per_step"] = round(imp[0]["cg_iterations_per_step"], 1)
        sizes.append(row)
    out = {"benchmark": "physical path: gelatin cube (FEM, symplectic substeps), dt = 1/60 s",
           "threads": args.threads, "simulated_s": args.seconds, "sizes": sizes,
           "wobble": wobble_energy_kept()}
    if not args.no_drops:
        out["drops"] = drops(args.drop_builders)
    out.update(cpu=platform.processor() or platform.machine(), cores=os.cpu_count(),
               loadavg_1min=round(os.getloadavg()[0], 2))
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
