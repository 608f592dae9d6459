"""``jellysim demo``: a jello cow (Spot, shipped in ``jellysim/data``) dropped on a table.

Everything physical about the demo lives in :data:`DEMO_SCENE` (a scene dictionary in the
format of :mod:`jellysim.scene`; its ``[body]`` table is unused because the body comes from
:func:`build_demo_body`).  Switching to another material preset or integrator is one edit there.
"""
from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np

__all__ = ["DEMO_SCENE", "DEMO_SHAPE", "build_demo_body", "demo_mesh", "run_demo"]

DEMO_SHAPE = {
    "length": 0.10,        # [m] longest side of the cow: dessert size
    "drop_height": 0.02,   # [m] gap between the hooves and the table at t = 0
    "points": 1500,        # points sampled inside (surface points are added)
    "connect": "delaunay",
    "seed": 7,
}
"""Geometry of the demo body (built by :func:`jellysim.build.build_body`)."""

DEMO_SCENE = {
    # unused by the demo (its body comes from build_demo_body), required by the scene format
    "body": {"type": "box", "points": 2},
    "springs": {"radius": 1.0},
    # real gelatin: density 1141 kg/m^3, springs calibrated to Young's modulus E, the physical
    # contact ground (restitution 0.3, Coulomb friction 0.6), the implicit integrator at a
    # frame-rate step.  E = 100 kPa is a firm gelatin (about 4:1 water:gelatin in the source
    # the preset cites, docs/physics.md): a cow's legs are slender columns, and at the
    # preset's dessert-soft 10 kPa a 10 cm cow buckles onto its belly, as a real one would.
    "material": {"preset": "gelatin", "youngs_modulus": 1.0e5},
    "integrator": {"name": "implicit", "dt": 1.0 / 60.0, "substeps": 2, "steps": 180},
    "output": {"every": 2, "vtu": False},
}
"""Physical settings of the demo (scene format): 3 s simulated, 30 frames per second."""


def demo_mesh():
    """Spot the cow (public domain, Keenan Crane): vertices [m] (m, 3), faces (f, 3), scaled to
    ``DEMO_SHAPE['length']``, standing on y = ``drop_height``, centred in x and z."""
    import trimesh

    with resources.as_file(resources.files("jellysim") / "data" / "spot.obj") as p:
        mesh = trimesh.load(p, process=False, force="mesh")
    mesh.merge_vertices(merge_tex=True, merge_norm=True)
    v = np.asarray(mesh.vertices, dtype=np.float64)
    v = v * (DEMO_SHAPE["length"] / np.ptp(v, axis=0).max())
    lo, hi = v.min(axis=0), v.max(axis=0)
    v -= [0.5 * (lo[0] + hi[0]), lo[1] - DEMO_SHAPE["drop_height"], 0.5 * (lo[2] + hi[2])]
    return v, np.asarray(mesh.faces, dtype=np.int64)


def build_demo_body(points: int | None = None):
    """The demo's jello body and its skin: ``(Body, Skin)``: Spot sampled and tetrahedralized
    by :func:`jellysim.build.build_body` (Delaunay, tets carved by the exact inside test), the
    skin Spot itself bound to the body's tets.  ``points``: sampled inside (default
    ``DEMO_SHAPE["points"]``)."""
    import warnings

    from .build import build_body
    from .geometry.mesh import Mesh
    from .params import REPORT_DENSITY
    from .skin import bind_body_skin

    verts, faces = demo_mesh()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Spot is clean; nothing to report
        body = build_body(Mesh.from_arrays(verts, faces, name="spot.obj"),
                          points=DEMO_SHAPE["points"] if points is None else int(points),
                          connect=DEMO_SHAPE["connect"],
                          density=DEMO_SCENE["material"].get("density", REPORT_DENSITY),
                          seed=DEMO_SHAPE["seed"])
    body.meta.update(builder="demo-spot", **DEMO_SHAPE)
    return body, bind_body_skin(body, verts, faces)


def run_demo(out_dir="out", *, frames: int | None = None, size=(960, 540), usd: bool = True,
             progress: bool = True, vtu: bool = False, overwrite: bool = False,
             points: int | None = None) -> dict:
    """Simulate the demo and write ``<out_dir>/demo.mp4`` (+ ``demo.usdc``); the run itself
    goes to ``<out_dir>/demo/``.  ``frames`` limits the number of saved frames (CI).
    An earlier demo's outputs there are refused (:class:`~jellysim.errors.JellysimError`)
    unless ``overwrite``, which deletes them first.  ``points``: see :func:`build_demo_body`.
    Returns the paths written and timings
    [s]."""
    import time

    from .io.trajectory import load_trajectory
    from .render.offscreen import RenderOptions
    from .render.video import render_trajectory
    from .runner import run_scene
    from .scene import Scene

    from .errors import JellysimError
    from .runner import prepare_out_dir

    t0 = time.perf_counter()
    out_dir = Path(out_dir)
    old = [out_dir / "demo.mp4", out_dir / "demo.usdc"]
    if not overwrite and any(p.exists() for p in old):
        raise JellysimError(f"--out {out_dir}: holds an earlier demo "
                            f"({', '.join(p.name for p in old if p.exists())}); pass "
                            "--overwrite to replace it, or choose another --out")
    prepare_out_dir(out_dir / "demo", overwrite=overwrite)
    for p in old:
        p.unlink(missing_ok=True)
    scene = Scene.from_dict(DEMO_SCENE, name="demo")
    body, skin = build_demo_body(points)
    steps = scene.steps if frames is None else max(1, int(frames) - 1) * scene.frame_every
    result = run_scene(scene, out_dir / "demo", progress=progress, vtu=vtu, steps=steps,
                       skin=skin, body=body)
    t_sim = time.perf_counter()
    traj = load_trajectory(result.trajectory)
    video = render_trajectory(traj, out_dir / "demo.mp4", RenderOptions(size=size),
                              progress=progress)
    t_render = time.perf_counter()
    written = {"trajectory": result.trajectory, "video": video}
    if usd:
        from .io.usd import export_usd

        written["usd"] = export_usd(traj, out_dir / "demo.usdc")
    written["seconds"] = {"simulate": t_sim - t0, "render": t_render - t_sim,
                          "total": time.perf_counter() - t0}
    written["points"] = body.point_count
    written["springs"] = body.spring_count
    written["frames"] = traj.frame_count
    return written
