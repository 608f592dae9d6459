"""Speed with and without competing processes: does jellysim degrade gracefully?

Runs three workloads in a fresh child process (so that threading settings taken at library
load apply), first on the machine as it is ("quiet"), then with one busy process per core
(``python -c "while True: pass"``, started and killed here), and prints JSON with both rates
and their ratio (quiet / busy: 1 = unaffected, 2 = what sharing every core with one other
process costs at most, worse = the threads hurt each other):

* ``paper``: ``examples/paper_cube.toml`` (the report's 600-point cube, all-pairs Provot) with
  jellysim's default settings, its 100 steps;
* ``paper_springs``: the same cube with Provot over the springs (the fast explicit step that
  ``bench_step`` times: many short parallel regions per step, the case that spin-waiting
  threads hurt most), 5000 steps;
* ``physical``: ``examples/gelatin_cube.toml`` (1331 points, the implicit integrator with
  contact: the demo's physics), 20 steps.
* ``demo`` (only when asked for with ``--workloads``): the simulation of ``jellysim demo``
  (the gelatin mould on the physical path), 10 frames; the body is built outside the timing;
* ``demo_cli`` (only when asked for): the whole ``jellysim demo`` command (simulation,
  rendering, MP4 and USD) in a subprocess, after one warm-up run; its "steps/s" is runs/s.

``--variants`` compares threading set-ups (each child gets that environment): ``default``
(jellysim as shipped: a 10 us spin, the thread count chosen by timing), ``passive``
(``JELLYSIM_THREADING=passive``: threads sleep at once, the default before session 32), ``spin`` (OpenMP's own default: ``OMP_WAIT_POLICY=active``-like spinning,
i.e. jellysim's setting undone), ``spin2k``/``spin10k``/``spin50k`` (the same with libgomp's
``GOMP_SPINCOUNT`` set: a short spin before sleeping), ``workqueue`` (numba's workqueue layer),
``threads1``.

With no thread count given, a Simulator first tries 1 and all threads (about ten pieces or
frames, ``jellysim.thread_choice``); the timing starts after that choice.

Run:  PYTHONPATH=src python -m benchmarks.bench_contention [--variants default,spin]
          [--busy N] [--repeats 3]

The machine is shared: the "quiet" figures include whatever else runs; compare the ratios of one
run, and report medians.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

VARIANTS = {
    "default": {},
    # jellysim's setting before session 32: threads sleep at once
    "passive": {"JELLYSIM_THREADING": "passive"},
    # what numba + libgomp do without jellysim's setting: spin for ~300k iterations
    "spin": {"JELLYSIM_THREADING": "spin"},
    "spin2k": {"JELLYSIM_THREADING": "spin", "GOMP_SPINCOUNT": "2000"},
    "spin10k": {"JELLYSIM_THREADING": "spin", "GOMP_SPINCOUNT": "10000"},
    "spin50k": {"JELLYSIM_THREADING": "spin", "GOMP_SPINCOUNT": "50000"},
    "workqueue": {"NUMBA_THREADING_LAYER": "workqueue"},
    "threads1": {"JELLYSIM_BENCH_THREADS": "1"},
}


def child(workloads: list[str]) -> dict:
    import warnings

    warnings.simplefilter("ignore")
    from jellysim.scene import Scene

    threads = os.environ.get("JELLYSIM_BENCH_THREADS")
    threads = int(threads) if threads else None
    out = {}
    for name in workloads:
        if name == "demo_cli":
            # the whole command: simulation, rendering, MP4 and USD (numba cache warmed first)
            import tempfile

            cmd = [sys.executable, "-m", "jellysim", "demo", "--quiet", "--out"]
            with tempfile.TemporaryDirectory() as tmp:
                subprocess.run(cmd + [str(Path(tmp) / "warm")], check=True, capture_output=True)
                t = time.perf_counter()
                subprocess.run(cmd + [str(Path(tmp) / "run")], check=True, capture_output=True)
                out[name] = 1.0 / (time.perf_counter() - t)  # runs per second
            continue
        if name in ("paper", "paper_springs"):
            sc = Scene.load(ROOT / "examples" / "paper_cube.toml")
            if name == "paper_springs":
                sc.params["provot"]["pairs"] = "springs"
            steps = 100 if name == "paper" else 5000
        elif name == "demo":
            from jellysim.demo import DEMO_SCENE, build_demo_body

            sc = Scene.from_dict(DEMO_SCENE, name="demo")
            body, _ = build_demo_body()
            sim = sc.simulator(sc.build_model(body), threads=threads)
            steps = 10
        else:
            sc = Scene.load(ROOT / "examples" / "gelatin_cube.toml")
            steps = 20
        if name != "demo":
            sim = sc.simulator(sc.build_model(), threads=threads)
        sim.advance(2)  # compile / load the cache outside the timing
        choice = getattr(sim, "_thread_choice", None)
        while choice and not choice.chosen:  # time the count chosen, not the first try
            sim.advance(max(1, steps // 10))
        t = time.perf_counter()
        sim.advance(steps)
        out[name] = steps / (time.perf_counter() - t)
        out["threads"] = sim.threads
    import numba

    try:
        out["layer"] = numba.threading_layer()
    except ValueError:  # (only demo_cli: numba ran in the command's own process)
        out["layer"] = "(in the subprocess)"
    out["OMP_WAIT_POLICY"] = os.environ.get("OMP_WAIT_POLICY")
    return out


def run_child(env_extra: dict, workloads: list[str]) -> dict:
    env = dict(os.environ)
    env.update(env_extra)
    env["PYTHONPATH"] = str(ROOT / "src") + os.pathsep + env.get("PYTHONPATH", "")
    cmd = [sys.executable, "-m", "benchmarks.bench_contention", "--child",
           ",".join(workloads)]
    res = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=1800)
    if res.returncode != 0:
        raise RuntimeError(res.stderr[-2000:])
    return json.loads(res.stdout.strip().splitlines()[-1])


def start_busy(count: int) -> list[subprocess.Popen]:
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(count)]


def stop_busy(procs) -> None:
    for p in procs:
        p.kill()
    for p in procs:
        p.wait()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--variants", default="default")
    ap.add_argument("--workloads", default="paper,paper_springs,physical")
    ap.add_argument("--busy", type=int, default=os.cpu_count(),
                    help="busy processes (default: one per core)")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    workloads = args.workloads.split(",")
    if args.child:
        print(json.dumps(child(args.child.split(","))))
        return
    run_child({}, workloads)  # fill numba's cache before anything is timed
    result = {"machine": {"cpus": os.cpu_count(), "platform": platform.platform(),
                          "busy_processes": args.busy,
                          "load_average_before": os.getloadavg()}, "variants": {}}
    for name in args.variants.split(","):
        env = VARIANTS[name]
        quiet, busy = [], []
        for _ in range(args.repeats):
            quiet.append(run_child(env, workloads))
            procs = start_busy(args.busy)
            try:
                time.sleep(0.2)
                busy.append(run_child(env, workloads))
            finally:
                stop_busy(procs)
        row = {"layer": quiet[0]["layer"], "threads": quiet[0].get("threads"),
               "OMP_WAIT_POLICY": quiet[0]["OMP_WAIT_POLICY"]}
        for w in workloads:
            q = statistics.median(r[w] for r in quiet)
            b = statistics.median(r[w] for r in busy)
            row[w] = {"quiet_steps_per_s": float(f"{q:.4g}"),
                      "busy_steps_per_s": float(f"{b:.4g}"), "slowdown": round(q / b, 2)}
            if w == "demo_cli":  # runs per second: say the seconds
                row[w].update(quiet_s=round(1.0 / q, 1), busy_s=round(1.0 / b, 1))
        result["variants"][name] = row
        print(json.dumps({name: row}), file=sys.stderr, flush=True)
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
