"""Benchmark: the physical (FEM) substep on the numba and Warp backends: substeps/s, tet-updates/s.

The body is the gelatin preset (Stable Neo-Hookean tets + the damping branch, E = 10 kPa) on a
cubic grid of ``cells^3`` cells (Kuhn tets, 6 per cell; no springs), 10 cm wide, resting on
the contact ground, with the substep the stability estimate picks at dt = 1/60 s.  A
tet-update is one tet's corner forces (and its damping strain) in one substep; per substep the
points are also gathered, integrated and checked.

Per size and backend it prints (JSON) the median of ``--repeats`` windows of
``Simulator.advance(frames)`` (one call: state uploaded once, copied back once, so on Warp this
is the device-resident rate) and of ``advance(1)`` per frame (what a run writing every frame
does: the state and the damping strains copied in and out per frame).  Run from the repository
root:

    PYTHONPATH=src python benchmarks/bench_fem_step.py [--cells 10 21 46] [--backend numba warp]
        [--device auto|cpu|cuda:0] [--dtype float32|float64] [--frames 10] [--repeats 3]
        [--threads N] [--numba-max-tets 1000000]

On a GPU (``pip install -e ".[gpu]"``), e.g.:

    PYTHONPATH=src python benchmarks/bench_fem_step.py --backend warp numba --dtype float32 \\
        --cells 21 46 100 --frames 5
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time
import warnings

import numpy as np


def gelatin_grid(cells: int, size: float = 0.1):
    from jellysim.body import Body
    from jellysim.geometry.lattice import grid_points, grid_tets
    from jellysim.physics.policy import physical_model
    from jellysim.presets import gelatin

    pts = grid_points((cells + 1) ** 3, [0, 0, 0], [size, size, size])
    body = Body(points=pts, springs=np.zeros((0, 2), dtype=np.int64), volume=size**3,
                tets=grid_tets(pts), meta={"distribution": "grid"})
    return physical_model(body, gelatin())


def time_backend(model, backend, args) -> dict:
    from jellysim.params import GroundModel, GroundParams
    from jellysim.simulator import Simulator

    kw = dict(dt=1 / 60, backend=backend, ground=GroundParams(model=GroundModel.CONTACT))
    if backend == "warp":
        kw.update(device=args.device, precision=args.dtype)
    else:
        kw.update(threads=args.threads)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulator(model, **kw)
    t = time.perf_counter()
    sim.advance(1)  # compile / load the kernel cache, upload, record
    first = time.perf_counter() - t
    sub = sim.substeps
    batch, per_frame = [], []
    for _ in range(args.repeats):
        t = time.perf_counter()
        sim.advance(args.frames)
        batch.append(args.frames * sub / (time.perf_counter() - t))
        t = time.perf_counter()
        for _ in range(args.frames):
            sim.advance(1)
        per_frame.append(args.frames * sub / (time.perf_counter() - t))
    assert np.all(np.isfinite(sim.state.x))
    tets = model.fem.tet_count
    med, med_f = statistics.median(batch), statistics.median(per_frame)
    out = {"first_call_s": round(first, 3), "substeps_per_frame": sub,
           "batch": {"substeps_per_s": round(med, 1), "tet_updates_per_s": med * tets,
                     "rates": [round(r, 1) for r in batch]},
           "per_frame": {"substeps_per_s": round(med_f, 1), "tet_updates_per_s": med_f * tets,
                         "realtime_factor": round(med_f / (60 * sub), 4)},
           "min_tet_volume_ratio": round(sim.min_tet_volume_ratio, 4)}
    if backend == "warp":
        out["device"], out["dtype"] = sim._k.device, sim._k.precision
    else:
        out["threads"] = sim.threads
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, nargs="+", default=[10, 21])
    ap.add_argument("--backend", nargs="+", choices=("numba", "warp"), default=["numba",
                                                                                "warp"])
    ap.add_argument("--device", default="auto", help="warp: auto, cpu, cuda, cuda:N")
    ap.add_argument("--dtype", choices=("float32", "float64"), default="float32",
                    help="warp precision")
    ap.add_argument("--frames", type=int, default=10, help="frames per timed window")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, default=None, help="numba threads")
    ap.add_argument("--numba-max-tets", type=int, default=1_000_000,
                    help="larger bodies are timed on warp only (numba: minutes per frame)")
    args = ap.parse_args(argv)
    result = {"benchmark": "physical substep (gelatin grid, FEM), dt = 1/60 s",
              "cpu": platform.processor() or platform.machine(), "cores": os.cpu_count(),
              "sizes": []}
    if "warp" in args.backend:
        import warp as wp

        from jellysim.kernels import warp_backend as wb

        result["warp"] = wp.__version__
        result["device"] = wb.device_info(wb.resolve_device(args.device))
    for cells in args.cells:
        model = gelatin_grid(cells)
        row = {"cells": cells, "points": model.point_count, "tets": model.fem.tet_count,
               "runs": {}}
        for backend in args.backend:
            if backend == "numba" and model.fem.tet_count > args.numba_max_tets:
                row["runs"][backend] = {"skipped": f"over --numba-max-tets "
                                                   f"{args.numba_max_tets}"}
                continue
            row["runs"][backend] = time_backend(model, backend, args)
        result["sizes"].append(row)
        print(json.dumps(row), flush=True, file=__import__("sys").stderr)
    result["loadavg_1min"] = round(os.getloadavg()[0], 2)
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
