"""Point-in-mesh throughput: jellysim vs trimesh (embree) vs libigl fast winding number.

    PYTHONPATH=src python benchmarks/bench_inside.py [MESH] [--points N] [--seed S]

Prints one JSON object: points/s for each method (best of --repeat runs, setup timed separately)
and the number of disagreements with libigl's exact ``winding_number`` (inside = w > 1/2), the
oracle, evaluated on all points (or on --oracle-points of them).
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np

DEFAULT_MESH = Path(__file__).resolve().parents[1].parent / "shared" / "meshes" / "bunny.obj"


def best_time(fn, repeat):
    best = float("inf")
    out = None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mesh", nargs="?", default=str(DEFAULT_MESH))
    ap.add_argument("--points", type=int, default=1_000_000)
    ap.add_argument("--oracle-points", type=int, default=None)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)

    import numba

    from jellysim.geometry import load_mesh
    from jellysim.geometry.inside import InsideQuery

    mesh = load_mesh(args.mesh)
    v, f = mesh.vertices, mesh.faces
    rng = np.random.default_rng(args.seed)
    lo, hi = mesh.bounds
    pts = rng.uniform(lo, hi, (args.points, 3))
    n = len(pts)
    res = {
        "mesh": Path(args.mesh).name,
        "faces": int(len(f)),
        "points": n,
        "cpu_count": os.cpu_count(),
        "machine": platform.processor() or platform.machine(),
        "numba_threads_max": numba.config.NUMBA_NUM_THREADS,
    }

    t = time.perf_counter()
    q = InsideQuery(mesh)
    res["jellysim_setup_first_s"] = time.perf_counter() - t  # includes loading the numba cache
    t = time.perf_counter()
    q = InsideQuery(mesh)
    res["jellysim_setup_s"] = time.perf_counter() - t
    q.query(pts[:1000])  # compile / load the numba cache
    ours = None
    for threads in (1, 2):
        if threads > numba.config.NUMBA_NUM_THREADS:
            continue
        numba.set_num_threads(threads)
        dt, out = best_time(lambda: q.query(pts), args.repeat)
        res[f"jellysim_{threads}thread_points_per_s"] = n / dt
        if ours is not None:
            res["jellysim_1_vs_2_threads_identical"] = bool(np.array_equal(ours, out))
        ours = out
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)

    methods = {"jellysim": ours}
    try:
        import trimesh

        tm = trimesh.Trimesh(v, f, process=False)
        res["trimesh_embree"] = bool(trimesh.ray.has_embree)
        tm.contains(pts[:1000])  # build the BVH
        dt, out = best_time(lambda: tm.contains(pts), 1)
        res["trimesh_contains_points_per_s"] = n / dt
        methods["trimesh_contains"] = out
    except ImportError as exc:
        res["trimesh_contains"] = f"unavailable: {exc}"
    try:
        import igl

        igl.fast_winding_number(v, f, pts[:1000])
        dt, w = best_time(lambda: igl.fast_winding_number(v, f, pts), 1)
        res["igl_fast_winding_number_points_per_s"] = n / dt
        methods["igl_fast_winding_number"] = w > 0.5

        m = args.oracle_points or n
        t = time.perf_counter()
        wex = igl.winding_number(v, f, pts[:m])
        res["oracle_igl_winding_number_points_per_s"] = m / (time.perf_counter() - t)
        res["oracle_points"] = m
        truth = wex > 0.5
        for name, ans in methods.items():
            res[f"{name}_errors"] = int(np.count_nonzero(ans[:m] != truth))
    except ImportError as exc:
        res["igl"] = f"unavailable: {exc}"
    if hasattr(os, "getloadavg"):
        res["load_average_1min_after"] = os.getloadavg()[0]
    print(json.dumps(res, indent=2))
    return res


if __name__ == "__main__":
    main()
