"""The physical path's thread count chosen by timing (``threads = None``) against 1 and all.

For each size of the bench cube of ``bench_physical.py`` (gelatin, a grid of ``cells^3``
cubes, 6 tets each, dropped 2 cm onto the contact ground) three simulators advance frame by
frame in turn, so that the shared machine's load hits all alike: one thread, all of numba's
threads, and the default (:mod:`jellysim.thread_choice`: starts on the size rule, times frames
on both, keeps the faster).  Printed per size: the median wall time per frame [ms] of each,
the ratios, which counts the default ran on (a string, one character a frame), and whether
the three trajectories are bitwise equal (they must be).

Run:  PYTHONPATH=src python -m benchmarks.bench_thread_choice [--cells 8 12 16] [--frames 60]
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def main(argv=None) -> None:
    import numba
    import numpy as np

    from bench_physical import cube
    from jellysim.params import GroundModel, GroundParams
    from jellysim.physics.policy import physical_model
    from jellysim.presets import gelatin
    from jellysim.simulator import Simulator

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, nargs="+", default=[8, 12, 16])
    ap.add_argument("--frames", type=int, default=60)
    args = ap.parse_args(argv)
    most = numba.config.NUMBA_NUM_THREADS
    out = {"numba_threads": most, "load_average_before": os.getloadavg(), "sizes": []}
    for cells in args.cells:
        model = physical_model(cube(cells), gelatin())
        ground = GroundParams(model=GroundModel.CONTACT)
        sims = {"one": Simulator(model, dt=1 / 60, ground=ground, threads=1),
                "all": Simulator(model, dt=1 / 60, ground=ground, threads=most),
                "chosen": Simulator(model, dt=1 / 60, ground=ground)}
        times = {k: [] for k in sims}
        ran = []
        for _ in range(args.frames):
            for name, sim in sims.items():
                t = time.perf_counter()
                sim.advance(1)
                times[name].append(time.perf_counter() - t)
            ran.append(str(sims["chosen"].threads))
        med = {k: statistics.median(v[2:]) * 1e3 for k, v in times.items()}  # (first: loads)
        x = [s.state.x for s in sims.values()]
        entry = {"points": model.point_count, "tets": model.fem.tet_count,
                 "substeps": sims["one"].substeps,
                 "ms_per_frame": {k: round(v, 2) for k, v in med.items()},
                 "all_over_one": round(med["one"] / med["all"], 3),
                 "chosen_over_one": round(med["one"] / med["chosen"], 3),
                 "chosen_over_best": round(min(med["one"], med["all"]) / med["chosen"], 3),
                 "chosen_threads": "".join(ran),
                 "bitwise_equal": bool(np.array_equal(x[0], x[1]) and np.array_equal(x[0], x[2]))}
        out["sizes"].append(entry)
        print(json.dumps(entry), flush=True)
    out["load_average_after"] = os.getloadavg()
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
