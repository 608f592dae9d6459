"""Time-step throughput: steps/s and spring-updates/s, beside this machine's memory bandwidth.

Scenes: the report's paper cube (600 edge-favouring points, r = 0.3, k = 2 N/m, delta = 0.8 kg/s,
dt = 0.01 s, tau = 0.1 %, ONE Provot pass over the springs, the report's ground) and the same
recipe at N = 10k, 100k, 1M points with r = 0.3 (600 / N)^(1/3) (so about 33 springs per point).
Every body starts resting on the ground (y in [0, 1]) so that the ground rule and Provot
corrections are active in every timed window; each window must end finite, else it is reported
as failed.  The report's dt = 0.01 s is kept for the paper scene; the larger edge-favouring
fields crowd many points into the cube's corners (up to hundreds of springs per point), which
pushes the forward-Euler limit dt < delta / lambda_max(K) far below 0.01 s, so those scenes use
dt = min(0.01 s, half the stability guard's estimate) with the report's k, delta and density.  A spring-update is one spring's force plus one Provot check: springs x steps/s.

The bandwidth bound (roofline): a STREAM triad ``a = b + s c`` (numba parallel, and numpy)
measures the streaming bandwidth B [bytes/s].  A spring-update must at least read what defines
the spring and cannot be recomputed: its other end's index (4 bytes as int32; the first end is
implicit in a per-point list), its rest length (8, f64) and its stiffness (8, f64) = 20 bytes;
and each step must read and write the point state, x and v read and written, a written:
5 x 24 = 120 bytes per point, shared by the point's springs.  So the minimum traffic is
``MIN_BYTES = 20 + 120 n / k`` bytes per spring-update (n points, k springs; about 24 bytes at
33 springs per point), independent of any layout, and no implementation on this machine
exceeds B / MIN_BYTES spring-updates/s; the script prints the achieved fraction of that bound.
For comparison, the present layout moves per spring in the fused sweep
(``_accelerations_provot_fused``): the index pair 16, rest 8, stiffness 8, second-list slot 4,
force and Provot scalars written 16 and read back 16, the other end's index 8 =
``LAYOUT_BYTES`` = 76 (plus the point arrays).

Run:  python -m benchmarks.bench_step [--sizes 600,10000,100000,1000000] [--repeats 5]
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import time

import numpy as np

LAYOUT_BYTES = 76
"""Bytes per spring the present layout moves in the fused sweep (see the docstring)."""
SPRING_MIN_BYTES = 20
POINT_MIN_BYTES = 120


def min_bytes_per_spring_update(n: int, k: int) -> float:
    """The least bytes a spring-update must move (the docstring's roofline)."""
    return SPRING_MIN_BYTES + POINT_MIN_BYTES * n / max(k, 1)


def stream_triad(n: int = 1 << 25, repeats: int = 5) -> dict:
    import numba
    from numba import njit, prange

    @njit(parallel=True, cache=False)
    def triad(a, b, c, s):
        for i in prange(a.shape[0]):
            a[i] = b[i] + s * c[i]

    a = np.zeros(n)
    b = np.ones(n)
    c = np.full(n, 2.0)
    out = {}
    for threads in (1, 2):
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
        triad(a, b, c, 3.0)
        times = []
        for _ in range(repeats):
            t = time.perf_counter()
            triad(a, b, c, 3.0)
            times.append(time.perf_counter() - t)
        out[f"threads_{threads}_GBps"] = 24 * n / float(np.median(times)) / 1e9
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        np.multiply(c, 3.0, out=a)
        np.add(a, b, out=a)
        times.append(time.perf_counter() - t)
    out["numpy_GBps"] = 40 * n / float(np.median(times)) / 1e9  # two passes: 16 + 24 bytes
    out["best_GBps"] = max(out.values())
    return out


def paper_scene(n: int, seed: int = 2010):
    from jellysim.body import Body
    from jellysim.geometry.connect import radius_springs
    from jellysim.geometry.sampling import box_field
    from jellysim.model import finalize

    r = 0.3 * (600 / n) ** (1 / 3)
    t = time.perf_counter()
    pts = box_field(n, [0, 0, 0], [1, 1, 1], distribution="edge", seed=seed)
    springs = radius_springs(pts, r)
    build = time.perf_counter() - t
    model = finalize(Body(points=pts, springs=springs, volume=1.0), stiffness=2.0,
                     density=1141.0, damping=0.8)
    return model, r, build


def scene_dt(model) -> float:
    from jellysim.stability import estimate_stability

    if model.particle_count == 600:
        return 0.01
    return min(0.01, 0.5 * estimate_stability(model, "paper", 0.01).dt_max)


def time_steps(model, backend: str, threads: int, steps: int, repeats: int, dt: float) -> dict:
    from jellysim.errors import SimulationError
    from jellysim.params import GroundParams, ProvotParams
    from jellysim.simulator import Simulator

    sim = Simulator(model, dt=dt, integrator="paper", backend=backend, threads=threads,
                    provot=ProvotParams(tau=0.001, loops=1, pairs="springs"),
                    ground=GroundParams(mu=0.1, nu=0.2), check_stability=False)
    sim.advance(1)  # compile / load cache, first touch
    rates = []
    corrected = []
    try:
        for _ in range(repeats):
            before = sim.state.x.copy()
            t = time.perf_counter()
            sim.advance(steps)
            rates.append(steps / (time.perf_counter() - t))
            corrected.append(float(np.abs(sim._scratch.max_corr).max()))
            assert np.all(np.isfinite(sim.state.x)) and not np.array_equal(before, sim.state.x)
    except SimulationError as exc:
        return {"failed": str(exc)}
    med = float(np.median(rates))
    return {"steps_per_s": med, "spring_updates_per_s": med * model.spring_count,
            "rates": rates, "provot_last_pass_max_correction_m": max(corrected),
            "on_ground": int(np.sum(sim.state.x[:, 1] == 0.0))}


def main(argv=None) -> None:
    import numba

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="600,10000,100000,1000000")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--numpy-max", type=int, default=100_000,
                    help="largest N timed with the numpy reference backend")
    args = ap.parse_args(argv)
    bw = stream_triad()
    result = {"machine": {"cpu_count": os.cpu_count(), "numba_threads": numba.config.NUMBA_NUM_THREADS,
                          "python": platform.python_version(), "numba": numba.__version__,
                          "numpy": np.__version__},
              "stream_triad": bw, "layout_bytes_per_spring": LAYOUT_BYTES,
              "scenes": []}
    for n in [int(s) for s in args.sizes.split(",")]:
        model, r, build = paper_scene(n)
        steps = max(2, min(2000, int(2e7 / max(model.spring_count, 1))))
        dt = scene_dt(model)
        entry = {"points": n, "radius_m": r, "springs": model.spring_count, "dt_s": dt,
                 "build_s": build, "steps_per_window": steps, "runs": {}}
        for backend, threads in [("numba", 1), ("numba", 2), ("numpy", 1)]:
            if backend == "numpy" and n > args.numpy_max:
                continue
            s = steps if backend == "numba" else max(1, steps // 50)
            entry["runs"][f"{backend}_{threads}t"] = time_steps(model, backend, threads, s,
                                                                args.repeats, dt)
        best = max((v.get("spring_updates_per_s", 0) for v in entry["runs"].values()),
                   default=0)
        mb = min_bytes_per_spring_update(model.particle_count, model.spring_count)
        bound = bw["best_GBps"] * 1e9 / mb
        entry["min_bytes_per_spring_update"] = mb
        entry["bandwidth_bound_spring_updates_per_s"] = bound
        entry["fraction_of_bandwidth_bound"] = best / bound
        result["scenes"].append(entry)
        print(json.dumps(entry), flush=True, file=__import__("sys").stderr)
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
