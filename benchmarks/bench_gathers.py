"""What one spring visit costs, and which part: the neighbour loads (gathers) or the arithmetic.

Every spring kernel of jellysim is a loop, per point, over its springs: load the other end's
position through an index, then a square root, a division and a few multiply-adds
(``kernels/spring_sums_numba.py``).  This script times that loop alone on synthetic lists
(600 random points in the unit cube, ``--springs`` each (128 by default), one thread, in L1)
in five forms:

* ``full``: the loop as the kernels write it (force and Provot sums, fast-math vectorised; the
  point's lists sliced and walked from 0);
* ``no_sqrt_div``: the same without the square root and the division;
* ``no_gather``: the same with the other end's position replaced by values read in order
  (no indexed load): what the arithmetic costs alone;
* ``inv_sqrt``: ``1 / sqrt`` as one division of the square root;
* ``unsliced``: ``full`` walking the lists from ``ptr[p]`` to ``ptr[p + 1]`` (the kernels' form
  until session 29): numba's wraparound of indices that might be negative turns every load of
  the lists into a scalar load through a corrected address.

Each form runs in a fresh process for each ``JELLYSIM_CPU`` mode (``native``, the default;
``nogather``; ``avx2``: :mod:`jellysim._cpu`), so each is compiled for those instructions.  Prints one JSON
object: ns per spring visit, median of 5 windows, per mode and form, and the instructions the
``full`` loop was compiled to (vector square roots and gathers counted in its assembly).

Run:  PYTHONPATH=src python -m benchmarks.bench_gathers [--springs 34]
"""
from __future__ import annotations

import json
import os
import subprocess
import sys

CHILD = r"""
import json, os, re, time, numpy as np
import jellysim  # (first: it sets numba's target)
import numba
from numba import njit, prange

FM = {"reassoc", "nsz", "contract"}

def make(mode):
    @njit(cache=False, parallel=True, fastmath=FM, error_model="numpy")
    def f(x, ptr, other, rest, stiff, tau, out):
        for p in prange(x.shape[0]):
            px, py, pz = x[p, 0], x[p, 1], x[p, 2]
            fx = fy = fz = sx = sy = sz = cnt = 0.0
            lo, hi = ptr[p], ptr[p + 1]
            if mode == 4:  # (the lists walked from ptr[p]: indices LLVM cannot prove >= 0)
                o, rr, kk, j0, j1 = other, rest, stiff, lo, hi
            else:  # (sliced and walked from 0, as the kernels do)
                o, rr, kk, j0, j1 = other[lo:hi], rest[lo:hi], stiff[lo:hi], 0, hi - lo
            for s in range(j0, j1):
                if mode == 2:
                    ex = rr[s] - px; ey = kk[s] - py; ez = 0.5 * rr[s] - pz
                else:
                    q = o[s]
                    ex = x[q, 0] - px; ey = x[q, 1] - py; ez = x[q, 2] - pz
                r0 = rr[s]
                s2 = ex * ex + ey * ey + ez * ez
                if mode == 1:
                    length = s2; inv = s2
                elif mode == 3:
                    inv = 1.0 / np.sqrt(s2) if s2 > 0.0 else 0.0
                    length = s2 * inv
                else:
                    length = np.sqrt(s2); inv = 1.0 / length if length > 0.0 else 0.0
                target = min(max(length, (1.0 - tau) * r0), (1.0 + tau) * r0)
                c = kk[s] * (length - r0) * inv
                cp = 0.5 * (length - target) * inv
                fx += c * ex; fy += c * ey; fz += c * ez
                sx += cp * ex; sy += cp * ey; sz += cp * ez
                cnt += 1.0 if cp != 0.0 else 0.0
            out[p, 0] = fx; out[p, 1] = fy; out[p, 2] = fz
            out[p, 3] = sx; out[p, 4] = sy; out[p, 5] = sz; out[p, 6] = cnt
    return f

numba.set_num_threads(1)
rng = np.random.default_rng(1)
n, d = 600, int(os.environ.get("BENCH_GATHERS_SPRINGS", "128"))
x = rng.random((n, 3)); out = np.zeros((n, 7))
other = rng.integers(0, n, n * d).astype(np.int32)
ptr = np.arange(n + 1) * d
rest = 0.3 * rng.random(n * d); stiff = np.full(n * d, 2.0)
res = {"codegen_features": "prefer-no-gather" if "+prefer-no-gather" in
       (numba.config.CPU_FEATURES or "").split(",") else "no AVX-512" if "-avx512f" in
       (numba.config.CPU_FEATURES or "").split(",") else "native"}
for mode, name in enumerate(("full", "no_sqrt_div", "no_gather", "inv_sqrt", "unsliced")):
    f = make(mode)
    f(x, ptr, other, rest, stiff, 0.1, out)
    ts = []
    for _ in range(5):
        t = time.perf_counter()
        for _ in range(30):
            f(x, ptr, other, rest, stiff, 0.1, out)
        ts.append((time.perf_counter() - t) / 30 / (n * d) * 1e9)
    res[name + "_ns"] = float(np.median(ts))
    if mode == 0:
        asm = "".join(f.inspect_asm().values())
        res["full_asm"] = {k: len(re.findall(p, asm)) for k, p in (
            ("vsqrtpd_zmm", r"vsqrtpd\s+%zmm"), ("vsqrtpd_ymm", r"vsqrtpd\s+%ymm"),
            ("gather_instructions", r"vgather|vpgather"))}
print(json.dumps(res))
"""


def main(argv=None) -> None:
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--springs", type=int, default=128, help="springs per point (the paper "
                    "scene has 34 on average)")
    args = ap.parse_args(argv)
    result = {"load_average": os.getloadavg(), "springs_per_point": args.springs, "modes": {}}
    for mode in ("native", "nogather", "avx2"):
        env = dict(os.environ, JELLYSIM_CPU=mode, NUMBA_NUM_THREADS="1",
                   BENCH_GATHERS_SPRINGS=str(args.springs))
        env.pop("NUMBA_CPU_FEATURES", None)
        res = subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True,
                             text=True, timeout=900)
        if res.returncode != 0:
            result["modes"][mode] = {"error": res.stderr.strip().splitlines()[-1:]}
            continue
        result["modes"][mode] = json.loads(res.stdout.strip().splitlines()[-1])
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
