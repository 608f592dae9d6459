"""A new user's first ``jellysim demo``: wall and CPU time on an empty numba cache.

Each repeat runs ``jellysim demo --quiet`` in a fresh process with a fresh, empty
``NUMBA_CACHE_DIR`` (so every kernel compiles, as after an install), and for comparison once
more with the cache that run filled (a warm run).  ``--src`` runs another checkout's
``src`` (e.g. an older commit's, from ``git worktree add /tmp/base <commit>``), alternating
with this one's when given twice or more; ``--no-warmup`` sets ``JELLYSIM_WARMUP=0`` (the
step then compiles after the body is built, in the same process).  Prints JSON: per source,
each repeat's wall [s], CPU [s] (user + system, the process and its children) and the
"first steps' start-up" the demo reports.

Run:  python -m benchmarks.bench_first_run [--repeats 2] [--src /tmp/base/src --src src]
"""
from __future__ import annotations

import argparse
import json
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _demo(src: str, cache: str, warmup: bool) -> dict:
    out = tempfile.mkdtemp(prefix="first_run_")
    env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONPATH=src,
               JELLYSIM_WARMUP="1" if warmup else "0")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    res = subprocess.run([sys.executable, "-m", "jellysim", "demo", "--out", out, "--quiet",
                          "--no-usd"], env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if res.returncode != 0:
        raise SystemExit(f"demo failed ({src}):\n{res.stderr[-2000:]}")
    said = re.search(r"\(([\d.]+) s of the simulating were the first steps' start-up",
                     res.stdout + res.stderr)
    return {"wall_s": round(wall, 2),
            "cpu_s": round(after.ru_utime - before.ru_utime + after.ru_stime
                           - before.ru_stime, 2),
            "startup_s": float(said.group(1)) if said else 0.0,
            "load_average": [round(v, 2) for v in os.getloadavg()]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--src", action="append", help="a checkout's src folder (repeatable)")
    ap.add_argument("--no-warmup", action="store_true")
    args = ap.parse_args()
    sources = args.src or [str(ROOT / "src")]
    runs = {s: {"cold": [], "warm": []} for s in sources}
    for _ in range(args.repeats):
        for src in sources:  # alternating: the same minutes for each
            cache = tempfile.mkdtemp(prefix="nbcache_")
            runs[src]["cold"].append(_demo(src, cache, not args.no_warmup))
            runs[src]["warm"].append(_demo(src, cache, not args.no_warmup))
    print(json.dumps({"cpu_count": os.cpu_count(), "warmup": not args.no_warmup,
                      "runs": runs}, indent=1))


if __name__ == "__main__":
    main()
