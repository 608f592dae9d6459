"""Benchmark: how much of its mesh a marching body fills, and the substeps it costs.

For each shipped test mesh and point count: ``build_body(mesh, size=..., points=n,
connect="marching")`` (the default, warped onto the surface; ``--staircase`` for the report's
grid, ``snap=False``), the volume its tets hold over the mesh's enclosed volume, the point
count, the worst tet quality, the body's largest extent over the mesh's, the build time, and the
explicit substeps per 1/60 s frame of the gelatin preset on the physical path (what the tets'
shape costs).  Prints JSON.  To compare two versions, run it with ``PYTHONPATH`` pointing at
each checkout's ``src``:

    PYTHONPATH=src python benchmarks/bench_marching_fill.py [--staircase]
"""
from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[1] / "tests" / "data"
CASES = [("sphere.obj", 0.1, (400, 1000, 3000)), ("spot.obj", 0.1, (800, 1500, 3000)),
         ("torus.obj", 0.08, (1500,)), ("suzanne.obj", 0.1, (2000,)),
         ("teapot.obj", 0.1, (2000,))]


def row(name: str, size: float, points: int, snap: bool) -> dict:
    import jellysim as js
    from jellysim.build import build_body
    from jellysim.geometry.tetra import tet_quality

    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the < 80 % fill warning of the staircase
        body = build_body(str(DATA / name), size=size, points=points, connect="marching",
                          density=1141.0, snap=snap)
    built = time.perf_counter() - t0
    sim = js.Simulator(js.physical_model(body, js.material("gelatin")), dt=1 / 60)
    out = {"mesh": name, "size_m": size, "points_asked": points, "points": body.point_count,
           "tet_volume_over_mesh": round(body.meta["tet_volume"] / body.volume, 3),
           "min_tet_quality": round(float(tet_quality(body.points, body.tets).min()), 3),
           "substeps_per_frame": int(sim.substeps), "build_s": round(built, 2),
           "largest_extent_over_size": round(float(np.ptp(body.points, axis=0).max()) / size,
                                             3)}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--staircase", action="store_true", help="snap=False: the report's grid")
    args = ap.parse_args()
    rows = [row(name, size, n, not args.staircase) for name, size, counts in CASES
            for n in counts]
    print(json.dumps({"benchmark": "marching fill", "warped": not args.staircase,
                      "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
