"""Benchmark: a 100k-point Delaunay body inside the bunny; prints one JSON object.

    PYTHONPATH=src python benchmarks/bench_build.py [--points 100000] [--repeat 3]

Needs ``../shared/meshes/bunny.obj`` (the Stanford bunny is not redistributed with jellysim),
trimesh and libigl.  The inside test is libigl's generalized winding number (> 0.5) until
``jellysim.geometry.inside`` exists; its time is part of ``delaunay_body`` (tet-centroid carving)
and is also reported on its own.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from jellysim.geometry.tetra import delaunay_body, tetgen_body  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--points", type=int, default=100_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--mesh", default=str(ROOT.parent / "shared" / "meshes" / "bunny.obj"))
    args = ap.parse_args()

    import igl
    import trimesh

    m = trimesh.load(args.mesh, force="mesh", process=True)
    m = trimesh.Trimesh(np.asarray(m.vertices), np.asarray(m.faces), process=True)
    v = np.asarray(m.vertices, dtype=np.float64)
    f = np.asarray(m.faces, dtype=np.int64)

    calls = {"n": 0, "points": 0, "seconds": 0.0}
    wn = {"exact": igl.winding_number, "fast": igl.fast_winding_number}

    def make_inside(kind):
        def inside(p):
            t = time.perf_counter()
            r = wn[kind](v, f, np.ascontiguousarray(p, dtype=np.float64)) > 0.5
            calls["n"] += 1
            calls["points"] += len(p)
            calls["seconds"] += time.perf_counter() - t
            return r
        return inside

    inside = make_inside("exact")

    # the point cloud: the surface vertices + uniform samples inside (seeded)
    t0 = time.perf_counter()
    rng = np.random.default_rng(0)
    need = args.points - len(v)
    lo, hi = v.min(axis=0), v.max(axis=0)
    chunks, have = [], 0
    while have < need:
        c = rng.uniform(lo, hi, size=(max(need - have, 1000) * 4, 3))
        c = c[inside(c)]
        chunks.append(c)
        have += len(c)
    pts = np.vstack([v, np.vstack(chunks)[:need]])
    t_sample = time.perf_counter() - t0

    runs = {}
    for kind in ("exact", "fast"):
        times, cpu_times, inside_times = [], [], []
        for _ in range(args.repeat):
            calls.update(n=0, points=0, seconds=0.0)
            t, c = time.perf_counter(), time.process_time()
            body = delaunay_body(pts, v, f, make_inside(kind))
            times.append(time.perf_counter() - t)
            cpu_times.append(time.process_time() - c)
            inside_times.append(calls["seconds"])
        runs[kind] = {
            "inside_test": f"igl.{wn[kind].__name__} > 0.5",
            "seconds": [round(x, 3) for x in times],
            "seconds_best": round(min(times), 3),
            "cpu_seconds": [round(x, 3) for x in cpu_times],
            "inside_test_seconds": [round(x, 3) for x in inside_times],
            "inside_test_points": calls["points"],
            "seconds_without_inside_test_best": round(
                min(a - b for a, b in zip(times, inside_times)), 3),
            "body_tets": int(len(body.tets)),
        }

    t = time.perf_counter()
    tg = tetgen_body(v, f)
    t_tetgen = time.perf_counter() - t

    out = {
        "benchmark": "build_delaunay_bunny",
        "mesh": Path(args.mesh).name,
        "mesh_vertices": int(len(v)),
        "mesh_faces": int(len(f)),
        "input_points": int(len(pts)),
        "inside_test_note": "libigl winding number > 0.5 as a stand-in for "
                            "jellysim.geometry.inside (exact: igl.winding_number; fast: "
                            "igl.fast_winding_number); sampling always uses the exact one",
        "sampling_seconds": round(t_sample, 3),
        "delaunay_body": runs,
        "target_seconds": 10.0,
        "body_points": body.point_count,
        "body_springs": body.spring_count,
        "body_volume": body.volume,
        "mesh_volume": float(m.volume),
        "volume_rel_error": body.volume / float(m.volume) - 1.0,
        "near_duplicates_removed": body.meta["near_duplicates_removed"],
        "slivers_removed": body.meta["slivers_removed"],
        "outside_removed": body.meta["outside_removed"],
        "tetgen_body_seconds": round(t_tetgen, 3),
        "tetgen_body_points": tg.point_count,
        "tetgen_volume_rel_error": tg.volume / float(m.volume) - 1.0,
        "cpu_count": os.cpu_count(),
        "load_average_1_5_15_min_at_end": [round(x, 2) for x in os.getloadavg()],
        "python": platform.python_version(),
        "numpy": np.__version__,
    }
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
