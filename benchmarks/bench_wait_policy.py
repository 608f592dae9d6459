"""How long idle threads spin before they sleep, on two threads, quiet and busy.

Each variant runs in a fresh child process (the wait policy is read when OpenMP loads) on two
workloads, first on the machine as it is ("quiet"), then with one ``python -c "while True:
pass"`` per core ("busy"):

* ``paper``: the paper scene of ``bench_step`` (600 points, one Jacobi Provot pass, two
  parallel regions per step), ``threads=2``, steps/s (median of 7 windows of 2,000 steps);
* ``physical``: the gelatin cube of ``bench_physical`` (``--cells``, default 12: 2,197 points,
  13,182 tets) dropped on the contact ground, ``threads=2``, ms per 1/60 s frame (median of 5
  windows of 3 frames).

Variants: ``shipped`` (jellysim's defaults: since session 32 libgomp's
``GOMP_SPINCOUNT=1000``, ``OMP_WAIT_POLICY=PASSIVE`` for other runtimes), ``passive``
(``JELLYSIM_THREADING=passive``, the default before: threads sleep at once), ``spinN``
(libgomp's ``GOMP_SPINCOUNT=N`` with OpenMP's active policy: spin N times, then sleep),
``spin`` (OpenMP's default: ``JELLYSIM_THREADING=spin``), ``tbb`` (numba's TBB layer; needs
``libtbb.so.12``: ``pip download tbb`` and unzip its ``data/lib`` into the folder given by
``--tbb-lib``), ``threads1`` (one thread, for reference), ``auto`` (the shipped set-up with no
thread count: the Simulator times 1 and 2 threads and keeps the faster, ``jellysim.thread_choice``;
timed after its first choice).

Run:  PYTHONPATH=src python -m benchmarks.bench_wait_policy [--variants shipped,auto,passive,threads1]
          [--rounds 3] [--tbb-lib DIR]

Rounds alternate the variants; the JSON gives every figure and the medians.  The machine is
shared: compare figures of one run.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _median_seconds(sim, steps: int, windows: int, choose_in: int) -> float:
    """Median wall time [s] per step of ``windows`` calls of ``advance(steps)``, after one
    step (compiling or loading the kernels) and, with a thread chooser (threads = None),
    calls of ``advance(choose_in)`` until its first choice."""
    sim.advance(1)
    choice = getattr(sim, "_thread_choice", None)
    while choice and not choice.chosen:
        sim.advance(choose_in)
    times = []
    for _ in range(windows):
        t = time.perf_counter()
        sim.advance(steps)
        times.append((time.perf_counter() - t) / steps)
    return statistics.median(times)


def child(workload: str, threads: int | None, cells: int) -> float:
    import warnings

    warnings.simplefilter("ignore")
    import jellysim  # noqa: F401  (first: it sets the wait policy before numba loads)
    from jellysim.params import GroundModel, GroundParams, ProvotParams
    from jellysim.simulator import Simulator

    if workload == "paper":
        from benchmarks.bench_step import paper_scene

        model = paper_scene(600)[0]
        sim = Simulator(model, dt=0.01, integrator="paper", threads=threads,
                        provot=ProvotParams(tau=0.001, loops=1, pairs="springs"),
                        ground=GroundParams(mu=0.1, nu=0.2), check_stability=False)
        return 1.0 / _median_seconds(sim, 2000, 7, choose_in=200)  # steps/s
    from benchmarks.bench_physical import cube
    from jellysim.physics.policy import physical_model
    from jellysim.presets import gelatin

    model = physical_model(cube(cells), gelatin())
    sim = Simulator(model, dt=1 / 60, ground=GroundParams(model=GroundModel.CONTACT),
                    threads=threads)
    return 1e3 * _median_seconds(sim, 3, 5, choose_in=1)  # ms per frame


def variant_env(name: str, tbb_lib: str | None) -> tuple[dict, int]:
    if name == "shipped":
        return {}, 2
    if name == "passive":
        return {"JELLYSIM_THREADING": "passive"}, 2
    if name == "threads1":
        return {}, 1
    if name == "auto":
        return {}, 0
    if name == "spin":
        return {"JELLYSIM_THREADING": "spin"}, 2
    if name.startswith("spin"):
        return {"JELLYSIM_THREADING": "spin", "GOMP_SPINCOUNT": name[4:]}, 2
    if name == "tbb":
        if not tbb_lib:
            raise SystemExit("variant tbb needs --tbb-lib DIR (holding libtbb.so.12)")
        lib = os.pathsep.join(filter(None, [tbb_lib, os.environ.get("LD_LIBRARY_PATH")]))
        return {"NUMBA_THREADING_LAYER": "tbb", "LD_LIBRARY_PATH": lib}, 2
    raise SystemExit(f"unknown variant {name!r}")


def run(name: str, workload: str, cells: int, tbb_lib: str | None) -> float:
    extra, threads = variant_env(name, tbb_lib)
    env = dict(os.environ, **extra)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), str(ROOT),
                                         env.get("PYTHONPATH", "")])
    cmd = [sys.executable, "-m", "benchmarks.bench_wait_policy", "--child", workload,
           "--threads", str(threads), "--cells", str(cells)]
    res = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=900)
    if res.returncode != 0:
        raise RuntimeError(res.stderr[-2000:])
    return float(res.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--threads", type=int, default=2, help=argparse.SUPPRESS)
    ap.add_argument("--cells", type=int, default=12)
    ap.add_argument("--variants", default="shipped,auto,passive,spin,threads1")
    ap.add_argument("--workloads", default="paper,physical")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--tbb-lib", default=None)
    args = ap.parse_args()
    if args.child:
        print(child(args.child, args.threads or None, args.cells))
        return
    variants = args.variants.split(",")
    workloads = args.workloads.split(",")
    out = {"load_average_before": os.getloadavg(), "cpu_count": os.cpu_count(),
           "units": {"paper": "steps/s", "physical": "ms per frame"}, "runs": {}}
    for mode in ("quiet", "busy"):
        busy = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
                for _ in range(os.cpu_count() or 1)] if mode == "busy" else []
        try:
            time.sleep(1.0 if busy else 0.0)
            for _ in range(args.rounds):
                for v in variants:
                    for w in workloads:
                        value = run(v, w, args.cells, args.tbb_lib)
                        out["runs"].setdefault(mode, {}).setdefault(w, {}).setdefault(
                            v, []).append(value)
                        print(json.dumps({"mode": mode, "workload": w, "variant": v,
                                          "value": value}), file=sys.stderr, flush=True)
        finally:
            for p in busy:
                p.kill()
                p.wait()
    out["medians"] = {m: {w: {v: statistics.median(vals) for v, vals in per.items()}
                          for w, per in ws.items()} for m, ws in out["runs"].items()}
    out["load_average_after"] = os.getloadavg()
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
