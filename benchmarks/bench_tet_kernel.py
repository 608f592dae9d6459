"""Benchmark: the numba tet-force kernel alone, ns per tet, with and without the damping branch.

The bench cube of ``bench_physical.py`` (gelatin, a grid of ``cells^3`` cubes, 6 tets each) at
a few sizes; ``tet_forces`` is called on the resting positions ``--calls`` times per window,
windows alternate between the two cases, and the median of ``--repeats`` windows is printed
(CPU time, one thread by default).  To compare two versions of the kernel, run the same script
with ``PYTHONPATH`` pointing at each checkout's ``src`` (the function and its arguments have
not changed since session 4):

    PYTHONPATH=src python benchmarks/bench_tet_kernel.py [--cells 6 10 21 30] [--repeats 9]
        [--threads 1]
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

sys.path.insert(0, str(Path(__file__).resolve().parent))


def time_kernel(cells: int, repeats: int, calls: int) -> dict:
    from bench_physical import cube
    from jellysim.kernels.fem_numba import tet_forces
    from jellysim.physics.policy import physical_model
    from jellysim.presets import gelatin

    model = physical_model(cube(cells), gelatin())
    fem = model.fem
    t = fem.tet_count
    q = np.zeros((t, 6))
    ft = fem.kernel_tuple(q, 1 / 60 / 40)
    g, decay = ft[8], ft[9]
    x = np.array(model.point_x0)
    tet_force = np.zeros((4 * t, 3))
    tet_j = np.zeros(t)
    out = {"points": model.point_count, "tets": t}
    runs = {"elastic": [], "damped": []}
    for case, gg in (("elastic", 0.0), ("damped", g)):
        tet_forces(x, ft, gg, decay, q, tet_force, tet_j)  # compile / load the cache
    for _ in range(repeats):
        for case, gg in (("elastic", 0.0), ("damped", g)):
            c0 = time.process_time()
            for _ in range(calls):
                tet_forces(x, ft, gg, decay, q, tet_force, tet_j)
            runs[case].append((time.process_time() - c0) / calls / t * 1e9)
    for case, vals in runs.items():
        out[f"{case}_ns_per_tet"] = round(statistics.median(vals), 2)
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, nargs="+", default=[6, 10, 21, 30])
    ap.add_argument("--repeats", type=int, default=9)
    ap.add_argument("--threads", type=int, default=1)
    args = ap.parse_args(argv)
    import numba

    numba.set_num_threads(args.threads)
    sizes = []
    for cells in args.cells:
        calls = max(3, int(2e6 / (6 * cells**3)))
        sizes.append(time_kernel(cells, args.repeats, calls))
    print(json.dumps({"benchmark": "numba tet forces (Stable Neo-Hookean, damping branch)",
                      "threads": args.threads, "sizes": sizes, "cpu": platform.machine(),
                      "cores": os.cpu_count(), "loadavg_1min": round(os.getloadavg()[0], 2)},
                     indent=2))


if __name__ == "__main__":
    main()
