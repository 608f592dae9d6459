"""The paper step computed from both ends of each spring, one region per step: is it faster?

Issue 11 quotes a plain numba loop (CSR per point, each spring computed twice, one thread) at
12,700 steps/s on the paper scene.  This script times, in one process and on the same scene as
``bench_step.py`` (600 edge-favouring points, r = 0.3, one Jacobi Provot pass over the springs,
the report's ground, dt = 0.01 s), that loop against the shipped fused step
(``kernels/steps_fused_numba.py``: each spring's length, force and Provot scalars computed once
and gathered by its second point):

* ``twice_scalar``: per point p, every spring of p (its first list, then its second list, the
  shipped step's summation order), length by ``sqrt`` and one division, no stores but the point's;
* ``twice_reassoc``: the same with ``fastmath = {"reassoc", "nsz", "contract"}`` so that LLVM
  vectorises the per-point sums (AVX-512 gathers, vector square roots);
* ``twice_rsqrt``: the same vectorised, ``1 / |d|`` from a float32 ``1 / sqrt`` refined by two
  float64 Newton steps (no float64 divider use).

Each variant runs the same 2,000 steps from the same state; medians of 7 (the first dropped).
The variants' trajectories are not bitwise the shipped step's (reassociated sums, other
rounding), so they are compared by speed only.

Run:  PYTHONPATH=src python -m benchmarks.bench_step_variants [--steps 2000] [--repeats 7]
      [--points 100000 --steps 20]   (the same recipe at 100k points: memory-bound sizes)
"""
from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np


def _make(fastmath, rsqrt: bool):
    from numba import njit, prange

    @njit(parallel=True, fastmath=fastmath, cache=False, nogil=True, error_model="numpy")
    def region(xr, vr, xw, vw, a, adj, consts, drift):
        ptr, nbr, rest, stiff, inv_mass = adj
        tau, damping, gy, dt, mu, nu = consts
        for p in prange(xr.shape[0]):
            fx = fy = fz = sx = sy = sz = cnt = 0.0
            px, py, pz = xr[p, 0], xr[p, 1], xr[p, 2]
            for s in range(ptr[p], ptr[p + 1]):
                q = nbr[s]
                ex, ey, ez = xr[q, 0] - px, xr[q, 1] - py, xr[q, 2] - pz
                s2 = ex * ex + ey * ey + ez * ez
                if rsqrt:
                    y = np.float64(np.float32(1.0) / np.sqrt(np.float32(s2)))
                    y = y * (1.5 - 0.5 * s2 * y * y)
                    y = y * (1.5 - 0.5 * s2 * y * y)
                    inv = y if s2 > 0.0 else 0.0
                    length = s2 * inv
                else:
                    length = np.sqrt(s2)
                    inv = 1.0 / length if length > 0.0 else 0.0
                r0 = rest[s]
                c = stiff[s] * (length - r0) * inv
                fx += c * ex
                fy += c * ey
                fz += c * ez
                target = min(max(length, (1.0 - tau) * r0), (1.0 + tau) * r0)
                cp = 0.5 * (length - target) * inv
                sx += cp * ex
                sy += cp * ey
                sz += cp * ez
                cnt += 1.0 if cp != 0.0 else 0.0
            w = inv_mass[p]
            ax = (fx - damping * vr[p, 0]) * w
            ay = (fy - damping * vr[p, 1]) * w + gy
            az = (fz - damping * vr[p, 2]) * w
            if cnt > 0:
                sx /= cnt
                sy /= cnt
                sz /= cnt
            nx, ny, nz = px + sx, py + sy, pz + sz
            vx, vy, vz = vr[p, 0], vr[p, 1], vr[p, 2]
            if ny < 0.0:
                ny, vy, vx, vz, ay = 0.0, 0.0, vx * mu, vz * mu, ay - nu * ay
            a[p, 0], a[p, 1], a[p, 2] = ax, ay, az
            if drift:
                nx, ny, nz = nx + vx * dt, ny + vy * dt, nz + vz * dt
                vx, vy, vz = vx + ax * dt, vy + ay * dt, vz + az * dt
            xw[p, 0], xw[p, 1], xw[p, 2] = nx, ny, nz
            vw[p, 0], vw[p, 1], vw[p, 2] = vx, vy, vz

    @njit(cache=False)
    def steps(nsteps, x, v, a, x2, v2, adj, consts):
        dt = consts[3]
        for p in range(x.shape[0]):
            for c in range(3):
                x[p, c] += v[p, c] * dt
                v[p, c] += a[p, c] * dt
        xr, vr, xw, vw = x, v, x2, v2
        for s in range(nsteps):
            region(xr, vr, xw, vw, a, adj, consts, s != nsteps - 1)
            xr, vr, xw, vw = xw, vw, xr, vr
        return xr

    return steps


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--points", type=int, default=600,
                    help="the paper recipe at this many points (bench_step's scenes)")
    args = ap.parse_args(argv)
    import numba

    from jellysim.params import GroundParams, ProvotParams
    from jellysim.simulator import Simulator

    from .bench_step import paper_scene, scene_dt

    model, _, _ = paper_scene(args.points)
    dt = scene_dt(model)
    n, ij = model.point_count, model.spring_ij
    rows = np.concatenate([ij[:, 0], ij[:, 1]])
    order = np.argsort(rows, kind="stable")      # first lists, then second lists: shipped order
    ptr = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(rows, minlength=n), out=ptr[1:])
    adj = (ptr, np.concatenate([ij[:, 1], ij[:, 0]])[order].astype(np.int32),
           np.tile(model.spring_rest_length, 2)[order], np.tile(model.spring_stiffness, 2)[order],
           np.broadcast_to(1.0 / np.asarray(model.point_mass, np.float64), (n,)).copy())
    tau, damping, mu, nu = 0.001, 0.8, 0.1, 0.2
    consts = (tau, damping, float(model.gravity[1]), dt, mu, nu)
    variants = {"twice_scalar": _make(False, False),
                "twice_reassoc": _make({"reassoc", "nsz", "contract"}, False),
                "twice_rsqrt": _make({"reassoc", "nsz", "contract"}, True)}
    out = {"points": n, "springs": int(len(ij)), "steps": args.steps, "load": os.getloadavg(),
           "steps_per_s": {}}
    for threads in (1, 2):
        sim = Simulator(model, dt=dt, integrator="paper", backend="numba", threads=threads,
                        provot=ProvotParams(tau=tau, loops=1, pairs="springs"),
                        ground=GroundParams(mu=mu, nu=nu), check_stability=False)
        sim.advance(1)
        x0, v0, a0 = sim.state.x.copy(), sim.state.v.copy(), sim.state.a.copy()
        numba.set_num_threads(threads)
        rates: dict[str, list] = {k: [] for k in ["shipped", *variants]}
        for _ in range(args.repeats):   # alternating, so drifts of the machine hit all alike
            sim.state.x[:], sim.state.v[:], sim.state.a[:] = x0, v0, a0
            t = time.perf_counter()
            sim.advance(args.steps)
            rates["shipped"].append(args.steps / (time.perf_counter() - t))
            for name, fn in variants.items():
                x, v, a = x0.copy(), v0.copy(), a0.copy()
                t = time.perf_counter()
                fn(args.steps, x, v, a, np.empty_like(x), np.empty_like(v), adj, consts)
                rates[name].append(args.steps / (time.perf_counter() - t))
        out["steps_per_s"][f"{threads}_thread"] = {
            k: float(np.median(r[1:])) for k, r in rates.items()}
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
