"""Sideways drift of a gelatin ball dropped straight down, per spring builder.

A 10 cm icosphere (trimesh, 642 vertices) is built with ``Body.from_mesh(..., size=None,
points=800, base=(0, 0.03, 0))`` (its bottom 3 cm above the ground), given the gelatin preset,
and dropped on the contact ground (friction 0.6, restitution 0.3).  A perfect ball dropped
straight down stays where it lands; whatever asymmetry the body has (its tets, a rough
bottom) the landing turns, through friction, into a sideways push, and a ball then rolls.
Prints JSON: per builder, the points, and the centre of mass's horizontal distance [mm] from
where it started and its horizontal speed [mm/s] at the end.

Run:  PYTHONPATH=src python -m benchmarks.bench_drift [--seconds 1.5]
      [--builders marching delaunay tetgen radius radius-inside]

``radius-inside`` is ``connect="radius", surface_samples=False`` (the report's way, as
``build_body`` and scenes default to: points only inside the mesh); ``radius`` is
``Body.from_mesh``'s default for that builder (points on the surface too).
"""
from __future__ import annotations

import argparse
import json
import tempfile
import warnings
from pathlib import Path


def drift(builder: str, seconds: float, mesh_path: str) -> dict:
    import numpy as np

    import jellysim as js

    extra = {}
    if builder == "radius-inside":
        builder, extra = "radius", {"surface_samples": False}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        body = js.Body.from_mesh(mesh_path, size=None, points=800, connect=builder,
                                 base=(0.0, 0.03, 0.0), **extra)
        model = js.physical_model(body, js.material("gelatin"))
        sim = js.Simulator(model, dt=1 / 60, ground=js.GroundParams(
            model=js.GroundModel.CONTACT))
    m = model.point_mass
    start = (m @ sim.state.x) / m.sum()
    sim.advance(int(round(seconds * 60)))
    com = (m @ sim.state.x) / m.sum()
    vcom = (m @ sim.state.v) / m.sum()
    return {"points": model.point_count,
            "drift_mm": round(1e3 * float(np.hypot(*(com - start)[[0, 2]])), 2),
            "speed_mm_s": round(1e3 * float(np.hypot(vcom[0], vcom[2])), 2)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=1.5)
    ap.add_argument("--builders", nargs="+",
                    default=["marching", "delaunay", "tetgen", "radius", "radius-inside"])
    args = ap.parse_args()
    import trimesh

    with tempfile.TemporaryDirectory() as tmp:
        path = str(Path(tmp) / "ball.obj")
        trimesh.creation.icosphere(subdivisions=3, radius=0.05).export(path)
        out = {b: drift(b, args.seconds, path) for b in args.builders}
    print(json.dumps({"seconds": args.seconds, "drop_m": 0.03, "diameter_m": 0.1,
                      "builders": out}, indent=1))


if __name__ == "__main__":
    main()
