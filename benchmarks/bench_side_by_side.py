"""Several jellysim runs at once on one machine (a parameter sweep's worker processes): the
steps/s of each and their total, for the threading set-ups.

Each process runs the paper scene of ``bench_step`` (600 points, one Jacobi Provot pass over
the springs) with no thread count given (the Simulator chooses by timing,
``jellysim.thread_choice``) for ``--seconds`` of wall time, the first choice included, in
``advance(500)`` calls.  Variants: ``default`` (jellysim as shipped: a 10 us spin),
``passive`` (``JELLYSIM_THREADING=passive``), ``threads1`` (``NUMBA_NUM_THREADS=1``).

Run:  PYTHONPATH=src python -m benchmarks.bench_side_by_side [--processes 1,2] [--rounds 2]

Prints one JSON line per variant, process count and round.  The machine is shared: compare
figures of one run.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

VARIANTS = {"default": {}, "passive": {"JELLYSIM_THREADING": "passive"},
            "threads1": {"NUMBA_NUM_THREADS": "1"}}


def child(points: int, seconds: float) -> None:
    import time
    import warnings

    warnings.simplefilter("ignore")
    import jellysim  # noqa: F401  (first: it sets the wait policy before numba loads)
    from benchmarks.bench_step import paper_scene
    from jellysim.params import GroundParams, ProvotParams
    from jellysim.simulator import Simulator

    sim = Simulator(paper_scene(points)[0], dt=0.01, integrator="paper",
                    provot=ProvotParams(tau=0.001, loops=1, pairs="springs"),
                    ground=GroundParams(mu=0.1, nu=0.2), check_stability=False)
    sim.advance(1)  # compile / load the cache
    t, steps = time.perf_counter(), 0
    while time.perf_counter() - t < seconds:
        sim.advance(500)
        steps += 500
    print(json.dumps({"steps_per_s": steps / (time.perf_counter() - t),
                      "threads_at_end": sim.threads}))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--points", type=int, default=600)
    ap.add_argument("--seconds", type=float, default=4.0)
    ap.add_argument("--processes", default="1,2")
    ap.add_argument("--variants", default="default,passive,threads1")
    ap.add_argument("--rounds", type=int, default=2)
    args = ap.parse_args()
    if args.child:
        child(args.points, args.seconds)
        return
    cmd = [sys.executable, "-m", "benchmarks.bench_side_by_side", "--child", "--points",
           str(args.points), "--seconds", str(args.seconds)]
    for rnd in range(args.rounds):
        for name in args.variants.split(","):
            env = dict(os.environ, **VARIANTS[name])
            env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), str(ROOT),
                                                 env.get("PYTHONPATH", "")])
            for count in map(int, args.processes.split(",")):
                procs = [subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE,
                                          text=True) for _ in range(count)]
                runs = [json.loads(p.communicate()[0].strip().splitlines()[-1])
                        for p in procs]
                print(json.dumps({"round": rnd, "variant": name, "processes": count,
                                  "load_average": os.getloadavg()[0], "runs": runs,
                                  "total_steps_per_s": round(sum(r["steps_per_s"]
                                                                 for r in runs))}),
                      flush=True)


if __name__ == "__main__":
    main()
