"""Peak memory of a run against its number of frames (issue 13: streaming output).

Each run is a fresh subprocess (``jellysim.runner.run_scene``, no .vtu) whose peak resident
set size (``ru_maxrss``) is reported, with the size of the trajectory written.  Prints JSON.

    PYTHONPATH=src python benchmarks/bench_memory.py [--steps 1000 100000] [--points 300]
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

SCENE = """
[body]
points = {points}
lower = [0.0, 0.05, 0.0]
upper = [0.3, 0.35, 0.3]
seed = 3
[springs]
radius = 0.08
stiffness = 300.0
[mass]
point_mass = 0.002
[physics]
damping = 0.002
[ground]
model = "contact"
[integrator]
name = "symplectic"
dt = 0.0005
steps = {steps}
[output]
every = {every}
vtu = false
"""

CHILD = """
import json, resource, sys, time
from jellysim.runner import run_scene
from jellysim.scene import Scene
scene = Scene.from_text(sys.argv[1], name="bench.toml")
t0 = time.perf_counter()
res = run_scene(scene, sys.argv[2], progress=False)
import os
print(json.dumps({"frames": res.frames, "seconds": time.perf_counter() - t0,
                  "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "trajectory_mib": os.path.getsize(res.trajectory) / 2**20}))
"""


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, nargs="+", default=[1000, 100000])
    ap.add_argument("--points", type=int, default=300)
    ap.add_argument("--every", type=int, default=10)
    args = ap.parse_args()
    rows = []
    for steps in args.steps:
        with tempfile.TemporaryDirectory() as tmp:
            text = SCENE.format(points=args.points, steps=steps, every=args.every)
            out = subprocess.run([sys.executable, "-c", CHILD, text, os.path.join(tmp, "run")],
                                 capture_output=True, text=True, check=True)
            row = json.loads(out.stdout.strip().splitlines()[-1])
            row.update(steps=steps, points=args.points, every=args.every)
            rows.append(row)
    base = rows[0]["peak_rss_mib"]
    for r in rows:
        r["peak_vs_first"] = r["peak_rss_mib"] / base
    print(json.dumps({"benchmark": "memory vs frames", "runs": rows}, indent=1))


if __name__ == "__main__":
    main()
