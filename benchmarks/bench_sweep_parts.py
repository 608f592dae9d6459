"""Where the report step's per-point sweep spends its time: the sweep with one part removed.

The sweep (:func:`jellysim.kernels.spring_sums_numba.point_force_provot`: per point, over its
visit list, the spring force and Provot's request) is copied here as a standalone kernel over
the paper scene's arrays (``bench_step.paper_scene``), with variants that drop one part:

* ``base``: the sweep as shipped (float64, fast-math flags as the kernels');
* ``noprovot``: the force only (no clamp, request or count);
* ``nosqrt``: the squared length instead of the length (wrong physics: timing only);
* ``nodiv``: a multiplication instead of the division;
* ``nogather``: the neighbour's position replaced by numbers computed from the list's own
  entries (no load of another point's coordinates);
* ``f32``: the whole sweep in float32 (positions, rest lengths, stiffnesses, arithmetic), with
  its largest force difference from ``base`` [N], and that over the stiffness [m]: the length
  error it amounts to (float32 rounds a 1 m coordinate by 6e-8 m).

Times are ns per spring visit (each spring is visited from both ends), one thread, medians of
``--repeats`` windows, the variants alternating within each window.  The differences are what
each part costs; they need not add up (the parts overlap in the out-of-order core).

Run:  PYTHONPATH=src python -m benchmarks.bench_sweep_parts [--sizes 600,100000] [--repeats 5]
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

VARIANTS = ("base", "noprovot", "nosqrt", "nodiv", "nogather", "f32")


def _make(variant: str):
    from numba import njit, prange

    from jellysim.kernels.spring_sums_numba import FASTMATH

    provot, sqrt, gather, div = (variant != "noprovot", variant != "nosqrt",
                                 variant != "nogather", variant != "nodiv")
    # constants compiled in (Python floats: np.float64 closure constants ran the loop 1.4x
    # slower at 600 points)
    real = np.float32 if variant == "f32" else float
    one, zero, half, t32, noise, three = (real(1.0), real(0.0), real(0.5), real(1e-3),
                                          real(1e-9), real(3.0))

    @njit(parallel=True, fastmath=FASTMATH, error_model="numpy", nogil=True)
    def sweep(x, ptr, other, rest, stiff, f, s):
        for p in prange(x.shape[0]):
            lo, hi = ptr[p], ptr[p + 1]
            oth, rr, kk = other[lo:hi], rest[lo:hi], stiff[lo:hi]
            px, py, pz = x[p, 0], x[p, 1], x[p, 2]
            fx = fy = fz = sx = sy = sz = cnt = zero
            for t in range(hi - lo):
                q = oth[t]
                if gather:
                    ex, ey, ez = x[q, 0] - px, x[q, 1] - py, x[q, 2] - pz
                else:
                    ex, ey, ez = rr[t] * half - px + q * noise, kk[t] * noise - py, rr[t] - pz
                r0 = rr[t]
                l2 = ex * ex + ey * ey + ez * ez
                length = np.sqrt(l2) if sqrt else l2
                if div:
                    inv = one / length if length > zero else zero
                else:
                    inv = length * three
                c = kk[t] * (length - r0) * inv
                fx += c * ex
                fy += c * ey
                fz += c * ez
                if provot:
                    target = min(max(length, (one - t32) * r0), (one + t32) * r0)
                    excess = length - target
                    excess = zero if abs(excess) <= noise * r0 else excess
                    cp = half * excess * inv
                    sx += cp * ex
                    sy += cp * ey
                    sz += cp * ez
                    cnt += one if cp != zero else zero
            f[p, 0], f[p, 1], f[p, 2] = fx, fy, fz
            s[p, 0], s[p, 1], s[p, 2], s[p, 3] = sx, sy, sz, cnt
    return sweep


def measure(n: int, repeats: int) -> dict:
    import numba

    from benchmarks.bench_step import paper_scene
    from jellysim.params import GroundParams, ProvotParams
    from jellysim.simulator import Simulator

    model = paper_scene(n)[0]
    sim = Simulator(model, dt=1e-5, integrator="paper", threads=1,
                    provot=ProvotParams(tau=0.001, loops=1, pairs="springs"),
                    ground=GroundParams(mu=0.1, nu=0.2), check_stability=False)
    sim.advance(20)  # (the state of a run, not the rest state)
    sp = sim._springs
    x = np.ascontiguousarray(sim.state.x)
    args = {v: (x, sp.visit_ptr, sp.visit_other, sp.visit_rest, sp.visit_stiff)
            for v in VARIANTS}
    args["f32"] = (x.astype(np.float32), sp.visit_ptr, sp.visit_other,
                   sp.visit_rest.astype(np.float32), sp.visit_stiff.astype(np.float32))
    outs = {v: (np.zeros((n, 3), args[v][0].dtype), np.zeros((n, 4), args[v][0].dtype))
            for v in VARIANTS}
    fns = {v: _make(v) for v in VARIANTS}
    numba.set_num_threads(1)
    for v in VARIANTS:
        fns[v](*args[v], *outs[v])
    visits = int(sp.visit_ptr[-1])
    reps = max(3, int(1e7 / visits))
    times = {v: [] for v in VARIANTS}
    for _ in range(repeats):
        for v in VARIANTS:
            t = time.perf_counter()
            for _ in range(reps):
                fns[v](*args[v], *outs[v])
            times[v].append((time.perf_counter() - t) / reps / visits * 1e9)
    f64, f32 = outs["base"][0], outs["f32"][0]
    diff = float(np.abs(f32 - f64).max())
    return {"points": n, "visits": visits,
            "ns_per_visit": {v: float(np.median(t)) for v, t in times.items()},
            "f32_largest_force_difference_N": diff,
            "f32_as_a_length_m": diff / float(sp.visit_stiff.max()),
            "largest_force_N": float(np.abs(f64).max())}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="600,100000")
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    import jellysim  # noqa: F401  (first: it chooses numba's target)

    print(json.dumps([measure(int(n), args.repeats) for n in args.sizes.split(",")], indent=2))


if __name__ == "__main__":
    main()
