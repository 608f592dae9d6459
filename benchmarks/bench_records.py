r"""Do the kernel records cost speed?  The explicit driver with records against the same kernels
called with positional arguments (the pre-records backend, imported as a package ``oldk`` holding
that commit's ``numba_backend.py``), alternating in one process on the paper-scene recipe.

Make the old package once (commit 6c02052 is the last one before the records)::

    mkdir -p /tmp/old/oldk && git show 6c02052:src/jellysim/kernels/numba_backend.py \
        > /tmp/old/oldk/numba_backend.py && printf \
        'STATUS_OK = 0\nSTATUS_NONFINITE = 1\nSTATUS_RUNAWAY = 2\n' > /tmp/old/oldk/__init__.py

Run:  PYTHONPATH=src:/tmp/old python -m benchmarks.bench_records [--sizes 600,100000]
Prints JSON: steps/s per size, thread count and variant (medians), and the ratio new / old.
"""
from __future__ import annotations

import argparse
import json
import statistics
import time

import numpy as np


def main() -> None:
    import numba

    from benchmarks.bench_step import paper_scene, scene_dt
    from jellysim.kernels import numba_backend as new
    from jellysim.kernels import records as rec
    from oldk import numba_backend as old

    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", default="600,100000")
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args()
    out = {}
    for n in [int(s) for s in args.sizes.split(",")]:
        model, _, _ = paper_scene(n)
        m = model
        dt = scene_dt(model)
        steps = max(2, min(2000, int(1e7 / m.spring_count)))
        k = m.spring_count
        x0 = m.point_x0.copy()
        springs, points = rec.spring_arrays(m), rec.point_arrays(m)
        po = rec.provot_options(1, 0.001)
        center = x0.mean(axis=0)
        gg = rec.ground_guard(True, 0.0, 0.1, 0.2, center, 1e8)
        ob = rec.obstacles()
        sc = rec.explicit_scratch(n, k)

        def run_new(x, v, a, s):
            return new.run_steps(s, dt, 0, x, v, a, springs, points, po, gg, ob, sc)

        def run_old(x, v, a, s):
            return old.run_steps(s, dt, 0, x, v, a, m.point_x0, m.point_inv_mass,
                                 float(m.damping), m.gravity, m.spring_ij, m.spring_rest_length,
                                 m.spring_stiffness, m.point_first_ptr, m.point_second_ptr,
                                 m.spring_second_slot, m.point_second_other, 1, 0.001, 0.0,
                                 False, False, False, True, 0.0, 0.1, 0.2, ob.kind, ob.data,
                                 0.0, center, 1e8, sc.spring_scalar, sc.dx, sc.count,
                                 sc.max_corr, sc.x_pre, sc.provot_scalar)

        for threads in (1, 2):
            numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
            rates = {"new": [], "old": []}
            finals = {}
            for rep in range(args.repeats):
                for name, fn in (("new", run_new), ("old", run_old)):
                    x, v, a = x0.copy(), np.zeros_like(x0), np.zeros_like(x0)
                    fn(x, v, a, 1)
                    t = time.perf_counter()
                    fn(x, v, a, steps)
                    rates[name].append(steps / (time.perf_counter() - t))
                    finals[name] = x
            med = {kk: statistics.median(vv) for kk, vv in rates.items()}
            out[f"{n}_points_{threads}t"] = {
                "steps_per_s_new": round(med["new"], 1), "steps_per_s_old": round(med["old"], 1),
                "ratio_new_over_old": round(med["new"] / med["old"], 3),
                "bitwise_equal": bool(np.array_equal(finals["new"], finals["old"]))}
            print(json.dumps({f"{n}_{threads}": out[f"{n}_points_{threads}t"]}), flush=True)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
