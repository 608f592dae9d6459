"""Benchmark: ``jellysim demo`` on the Warp backend against the default (numba) backend.

Runs the demo (the gelatin mould slid onto a plate, 181 frames by default) with numba, then
with Warp in each ``--dtype``, and prints (JSON) per Warp run: the largest point distance over
all frames relative to the jello's largest extent, the mean and largest absolute difference of
the decoded video frames (0-255 per channel), and the simulate/render times of every run.
Run from the repository root:

    PYTHONPATH=src python benchmarks/bench_warp_demo.py [--frames 181] [--device auto]
        [--dtype float64 float32] [--size 960x540] [--out out/bench_warp_demo]
"""
from __future__ import annotations

import argparse
import json
import os
import tempfile
from pathlib import Path

import numpy as np


def run(out: Path, backend: str, args, precision=None):
    import imageio.v3 as iio

    from jellysim.demo import run_demo
    from jellysim.io.trajectory import load_trajectory

    w, h = (int(v) for v in args.size.split("x"))
    res = run_demo(out, frames=args.frames, size=(w, h), usd=False, progress=False,
                   backend=backend, precision=precision,
                   device=args.device if backend == "warp" else None, overwrite=True)
    traj = load_trajectory(out / "demo" / "trajectory.npz")
    video = np.asarray(iio.imread(out / "demo.mp4")).astype(np.float64)
    return traj, video, {k: round(v, 2) for k, v in res["seconds"].items()}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=None, help="default: the demo's 181")
    ap.add_argument("--device", default="auto")
    ap.add_argument("--dtype", nargs="+", default=["float64", "float32"])
    ap.add_argument("--size", default="960x540")
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    root = Path(args.out or tempfile.mkdtemp(prefix="bench_warp_demo_"))
    ref, ref_video, ref_s = run(root / "numba", "numba", args)
    size = float(np.ptp(ref.positions[0], axis=0).max())
    result = {"frames": ref.frame_count, "points": int(ref.positions.shape[1]),
              "body_size_m": size, "numba_seconds": ref_s, "warp": {}}
    for dtype in args.dtype:
        traj, video, secs = run(root / f"warp_{dtype}", "warp", args, dtype)
        d = np.abs(traj.positions - ref.positions).max(axis=(1, 2))
        pix = np.abs(video - ref_video)
        result["warp"][dtype] = {
            "seconds": secs, "max_distance_m": float(d.max()),
            "max_distance_over_size": float(d.max() / size),
            "distance_at_frames": {int(i): float(d[i]) for i in
                                   np.linspace(0, len(d) - 1, 7).astype(int)},
            "video_mean_abs_diff": float(pix.mean()), "video_max_abs_diff": float(pix.max()),
            "video_worst_frame_mean_abs_diff": float(pix.mean(axis=(1, 2, 3)).max())}
    result["loadavg_1min"] = round(os.getloadavg()[0], 2)
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
