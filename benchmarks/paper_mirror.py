"""The report's step mirrors the paper cube as it lands: measured, per 0.1 s.

For each frame of ``examples/paper_cube.toml`` (the report's section 5.1 run, its step
exactly): the rms distance [m] of the frame's points from the best rigid motion of the starting
points (Kabsch, rotation only) and from the best rigid motion combined with a reflection, and
the volume [m^3] the skin encloses (negative: inside out).  Prints JSON.

Run:  PYTHONPATH=src python benchmarks/paper_mirror.py [--out out/paper_mirror]
"""
from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path

import numpy as np


def best_fit_rms(a: np.ndarray, b: np.ndarray, reflect: bool) -> float:
    """rms [m] of ``b`` (n, 3) about the best rotation (``reflect``: rotation and reflection)
    of ``a`` (n, 3), both centred."""
    a = a - a.mean(axis=0)
    b = b - b.mean(axis=0)
    u, _, vt = np.linalg.svd(a.T @ b)
    d = np.sign(np.linalg.det(u @ vt)) * (-1.0 if reflect else 1.0)
    r = u @ np.diag([1.0, 1.0, d]) @ vt
    return float(np.sqrt(((a @ r - b) ** 2).sum(axis=1).mean()))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/paper_mirror")
    args = ap.parse_args(argv)
    from jellysim.io.trajectory import load_trajectory
    from jellysim.runner import run_scene
    from jellysim.scene import Scene

    out = Path(args.out)
    shutil.rmtree(out, ignore_errors=True)
    scene = Scene.load(Path(__file__).resolve().parents[1] / "examples" / "paper_cube.toml")
    t = load_trajectory(run_scene(scene, out, progress=False, vtu=False).trajectory)
    f = t.skin.faces
    rows = []
    for k in range(0, t.frame_count, 10):
        v = t.skin_positions(k)
        volume = float(np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])).sum()
                       / 6.0)
        rows.append({"t_s": round(float(t.times[k]), 6),
                     "rotation_rms_m": best_fit_rms(t.rest_positions, t.positions[k], False),
                     "reflection_rms_m": best_fit_rms(t.rest_positions, t.positions[k], True),
                     "skin_volume_m3": volume})
    print(json.dumps({"scene": "examples/paper_cube.toml", "frames": rows}, indent=2))


if __name__ == "__main__":
    main()
