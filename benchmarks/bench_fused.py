r"""The explicit step against the kernels of an earlier commit, alternating in one process.

Times ``run_steps`` (the report's integrator, one Jacobi Provot pass over the springs, the
report's ground: the case ``bench_step`` times) three ways on the same scene, one after the
other in each repeat so that the shared machine's load hits all alike:

* ``old``: the kernels of an earlier commit, imported as a package ``oldk`` (a copy of that
  commit's ``src/jellysim/kernels``);
* ``new``: this tree's kernels, float64;
* ``new_f32``: the same with the state in float32 (``precision = "float32"``).

Make the old package once (``7f4645f``: the last commit before the gather step, where each
spring was computed once and its scalars gathered through slots; ``35b3a87``: the last before
the fused step)::

    rm -rf /tmp/k12old && mkdir -p /tmp/k12old && git archive 7f4645f src/jellysim/kernels \
        | tar -x -C /tmp/k12old && mv /tmp/k12old/src/jellysim/kernels /tmp/k12old/oldk
    sed -i 's/from \.\.errors/from jellysim.errors/; s/from \.\._numba_cache/from jellysim._numba_cache/' \
        /tmp/k12old/oldk/__init__.py /tmp/k12old/oldk/_numba_opts.py /tmp/k12old/oldk/warp_backend.py

Run:  PYTHONPATH=src:/tmp/k12old python -m benchmarks.bench_fused [--sizes 600,100000]
Prints JSON: per size and thread count the median steps/s and spring-updates/s of each variant,
the ratios, the same from the process's CPU time (``cpu_*``: steps per CPU-second of all its
threads, less sensitive to other processes taking the cores; on 2 threads it also counts the
threads' waiting), whether ``new`` is bitwise ``old``, the largest float32 - float64 position
difference [m] after the timed steps, and the load average before and after.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import time

import numpy as np


def main(argv=None) -> None:
    import numba

    from benchmarks.bench_step import paper_scene, scene_dt
    from jellysim.kernels import numba_backend as new
    from jellysim.kernels import records as rec
    from oldk import numba_backend as old

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="600,100000")
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args(argv)
    out = {"load_average_before": os.getloadavg(), "cpu_count": os.cpu_count(), "scenes": {}}
    for n in [int(s) for s in args.sizes.split(",")]:
        model, _, _ = paper_scene(n)
        m = model
        k = m.spring_count
        dt = scene_dt(model)
        steps = max(4, min(2000, int(3e7 / k)))
        x0 = m.point_x0
        springs, points = rec.spring_arrays(m), rec.point_arrays(m)
        po = rec.provot_options(1, 0.001)
        gg = rec.ground_guard(True, 0.0, 0.1, 0.2, x0.mean(axis=0), 1e8)
        ob = rec.obstacles()
        scratch = {np.float64: rec.explicit_scratch(n, k), np.float32:
                   rec.explicit_scratch(n, k, np.float32)}
        variants = {"old": (old, np.float64, springs), "new": (new, np.float64, springs),
                    "new_f32": (new, np.float32, springs)}
        for threads in (1, 2):
            numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
            rates = {name: [] for name in variants}
            cpu = {name: [] for name in variants}
            finals = {}
            for _ in range(args.repeats):
                for name, (mod, dtype, springs) in variants.items():
                    x = x0.astype(dtype)
                    v, a = np.zeros_like(x), np.zeros_like(x)
                    sc = scratch[dtype]
                    run = mod.run_steps
                    run(1, dt, 0, x, v, a, springs, points, po, gg, ob, sc)
                    c = time.process_time()
                    t = time.perf_counter()
                    done, status = run(steps, dt, 0, x, v, a, springs, points, po, gg,
                                       ob, sc)
                    rates[name].append(steps / (time.perf_counter() - t))
                    cpu[name].append(steps / max(time.process_time() - c, 1e-9))
                    assert done == steps and status == 0, (name, done, status)
                    finals[name] = x
            med = {name: statistics.median(r) for name, r in rates.items()}
            entry = {f"steps_per_s_{name}": round(r, 2) for name, r in med.items()}
            entry.update({f"spring_updates_per_s_{name}": float(f"{r * k:.3g}")
                          for name, r in med.items()})
            cmed = {name: statistics.median(r) for name, r in cpu.items()}
            entry.update({f"cpu_steps_per_s_{name}": round(r, 2) for name, r in cmed.items()})
            entry["cpu_ratio_new_over_old"] = round(cmed["new"] / cmed["old"], 3)
            entry["cpu_ratio_f32_over_old"] = round(cmed["new_f32"] / cmed["old"], 3)
            entry["ratio_new_over_old"] = round(med["new"] / med["old"], 3)
            entry["ratio_f32_over_old"] = round(med["new_f32"] / med["old"], 3)
            entry["new_bitwise_old"] = bool(np.array_equal(finals["new"], finals["old"]))
            entry["f32_max_abs_diff_m"] = float(np.abs(finals["new_f32"] - finals["new"]).max())
            entry["steps_per_window"] = steps
            entry["springs"] = k
            out["scenes"][f"{n}_points_{threads}t"] = entry
            print(json.dumps({f"{n}_{threads}t": entry}), flush=True)
        del model, springs, scratch, variants
    out["load_average_after"] = os.getloadavg()
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
