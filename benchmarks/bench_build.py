"""Build benchmark: a 100k-point Delaunay body from bunny.obj, radius springs for 1M points.

    python -m benchmarks.bench_build [--points 100000] [--radius-points 1000000] [--repeat 3]
                                     [--kdtree] [--calibrate] [--report-way]

The Delaunay body is built by the real pipeline, ``jellysim.build.build_body(bunny.obj,
points=N, connect="delaunay")``: the exact slicing inside test (``InsideQuery``), the report's
sampling (uniform field, keep the inside points until exactly N), the surface sampled (its
vertices, sharp edges and faces; ``--report-way``: its vertices only), then ``delaunay_body``
(near duplicates, Qhull, slivers, carving).  The mesh load is not timed.  ``--calibrate`` also
times ``calibrate_springs`` on that body (E = 10 kPa: the kinematic and static solves,
multigrid-preconditioned CG; wall and CPU seconds, and the mean calibrated stiffness).
Radius springs: the report's scene recipe at 1M edge-favouring points, r = 0.3 (600 / N)^(1/3),
with the parallel cell grid (``method="grid"``) and, with ``--kdtree``, cKDTree.query_pairs.
Needs ``../shared/meshes/bunny.obj`` (Stanford terms: not redistributed with jellysim).
"""
from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> None:
    import warnings

    from jellysim.build import build_body
    from jellysim.geometry import load_mesh
    from jellysim.geometry.connect import radius_springs
    from jellysim.geometry.sampling import box_field

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=100_000)
    ap.add_argument("--radius-points", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--kdtree", action="store_true", help="also time cKDTree.query_pairs")
    ap.add_argument("--calibrate", action="store_true",
                    help="also time calibrate_springs on the Delaunay body")
    ap.add_argument("--report-way", action="store_true",
                    help="Delaunay body from the mesh vertices only (surface_samples=False)")
    ap.add_argument("--mesh", default=str(ROOT.parent / "shared" / "meshes" / "bunny.obj"))
    args = ap.parse_args(argv)

    out = {"cpu_count": os.cpu_count()}
    mesh = load_mesh(args.mesh)
    build_body(mesh, points=2000, connect="delaunay")  # compile / load numba caches
    times = []
    for _ in range(args.repeat):
        t = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            body = build_body(mesh, points=args.points, connect="delaunay", seed=0,
                              surface_samples=not args.report_way)
        times.append(time.perf_counter() - t)
    out["delaunay_bunny"] = {
        "mesh": Path(args.mesh).name, "requested_points": args.points,
        "seconds": times, "seconds_median": float(np.median(times)), "target_seconds": 10.0,
        "body_points": body.point_count, "body_tets": int(len(body.tets)),
        "body_springs": body.spring_count, "tet_volume": body.meta["tet_volume"],
        "mesh_volume": body.volume,
        "tet_volume_rel_error": body.meta["tet_volume"] / body.volume - 1.0,
        "surface_samples": not args.report_way,
    }
    if args.calibrate:
        from jellysim.physics.material import calibrate_springs

        t, c = time.perf_counter(), time.process_time()
        k = calibrate_springs(body, 1e4)
        out["delaunay_bunny"]["calibrate_seconds"] = time.perf_counter() - t
        # CPU seconds of this process (all its threads): on a shared machine the wall time
        # measures the other processes too
        out["delaunay_bunny"]["calibrate_cpu_seconds"] = time.process_time() - c
        out["delaunay_bunny"]["calibrated_k_mean_N_per_m"] = float(k.mean())
    print(json.dumps(out["delaunay_bunny"]), flush=True, file=__import__("sys").stderr)

    n = args.radius_points
    r = 0.3 * (600 / n) ** (1 / 3)
    pts = box_field(n, [0, 0, 0], [1, 1, 1], distribution="edge", seed=1)
    radius_springs(pts[:2000], r, method="grid")  # compile / load cache
    methods = ["grid"] + (["kdtree"] if args.kdtree else [])
    out["radius_1M"] = {"points": n, "radius_m": r, "target_seconds": 10.0}
    for method in methods:
        times = []
        for _ in range(args.repeat if method == "grid" else 1):
            t = time.perf_counter()
            springs = radius_springs(pts, r, method=method)
            times.append(time.perf_counter() - t)
        out["radius_1M"][method] = {"seconds": times, "seconds_median": float(np.median(times)),
                                    "springs": int(len(springs))}
        del springs
    out["load_average_at_end"] = list(os.getloadavg())
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
