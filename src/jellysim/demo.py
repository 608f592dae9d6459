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
    "length": 0.40,        # [m] longest side of the cow
    "drop_height": 0.03,   # [m] gap between the hooves and the table at t = 0
    "spacing": 0.024,      # [m] grid spacing of the interior points
    "radius_factor": 1.75,  # spring radius = factor x spacing
    "seed": 7,
}
"""Geometry of the demo body."""

DEMO_SCENE = {
    # unused by the demo (its body comes from build_demo_body), required by the scene format
    "body": {"type": "box", "points": 2},
    "springs": {"connect": "radius", "radius": 1.0, "stiffness": 8000.0},
    "mass": {"density": 1141.0},
    "physics": {"damping": 0.003, "gravity": [0.0, -9.8, 0.0]},
    "integrator": {"name": "symplectic", "dt": 2e-4, "steps": 12500},
    "provot": {"enabled": True, "tau": 0.02, "loops": 5, "pairs": "springs",
               "order": "jacobi", "velocity_update": True},
    "ground": {"enabled": True, "model": "paper", "height": 0.0, "mu": 0.1, "nu": 0.2},
    "output": {"every": 167, "vtu": False},
}
"""Physical settings of the demo (scene format).  2.5 s simulated, 30 frames per second."""


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


def build_demo_body():
    """The demo's jello body and its skin: ``(Body, Skin)``.

    Interim builder (until the mesh-to-body builders are merged): points on a jittered grid
    inside Spot (trimesh's ``contains``) plus evenly spread points on its surface, mirrored
    left-right, radius springs, mass from density x mesh volume; the skin is Spot bound to the Delaunay
    cells of the points (:func:`jellysim.skin.body_tets`)."""
    import trimesh

    from .body import Body
    from .geometry.connect import radius_springs
    from .geometry.sampling import morton_order
    from .skin import bind_body_skin

    verts, faces = demo_mesh()
    mesh = trimesh.Trimesh(verts, faces, process=False)
    h = DEMO_SHAPE["spacing"]
    rng = np.random.default_rng(DEMO_SHAPE["seed"])
    lo, hi = mesh.bounds
    # Spot is left-right symmetric about x = 0 (demo_mesh centres it): build the left half and
    # mirror it, so the body has no built-in lean that would tip the cow over on landing.
    xs = -np.arange(0.5 * h, max(-lo[0], hi[0]), h)
    axes = [xs, np.arange(lo[1] + 0.5 * h, hi[1], h), np.arange(lo[2] + 0.5 * h, hi[2], h)]
    half = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    half += rng.uniform(-0.15 * h, 0.15 * h, half.shape)
    half[:, 0] = np.minimum(half[:, 0], -0.3 * h)
    mirror = half * [-1.0, 1.0, 1.0]
    from scipy.spatial import cKDTree

    dense, _ = trimesh.sample.sample_surface(mesh, 30000, seed=DEMO_SHAPE["seed"])
    tree = cKDTree(np.asarray(dense))
    keep = mesh.contains(half) & mesh.contains(mirror)
    keep &= np.minimum(tree.query(half)[0], tree.query(mirror)[0]) > 0.45 * h
    inside = np.concatenate([half[keep], mirror[keep]])
    import logging

    quiet = logging.getLogger("trimesh")
    level = quiet.level
    quiet.setLevel(logging.ERROR)  # "only got N/4000 samples" is expected: spacing rules
    try:
        surface, _ = trimesh.sample.sample_surface_even(mesh, 4000, radius=0.8 * h,
                                                        seed=DEMO_SHAPE["seed"])
    finally:
        quiet.setLevel(level)
    surface = np.asarray(surface)
    surface = surface[surface[:, 0] < -0.3 * h]
    surface = np.concatenate([surface, surface * [-1.0, 1.0, 1.0]])
    points = np.concatenate([inside, surface])
    points = points[morton_order(points)]
    springs = radius_springs(points, DEMO_SHAPE["radius_factor"] * h)
    body = Body(points=points, springs=springs, volume=float(mesh.volume),
                meta={"builder": "demo-spot", **DEMO_SHAPE})
    skin = bind_body_skin(body, verts, faces)
    return body, skin


def run_demo(out_dir="out", *, frames: int | None = None, size=(960, 540), usd: bool = True,
             progress: bool = True, vtu: bool = False) -> dict:
    """Simulate the demo and write ``<out_dir>/demo.mp4`` (+ ``demo.usdc``); the run itself
    goes to ``<out_dir>/demo/``.  ``frames`` limits the number of saved frames (CI).
    Returns the paths written and timings [s]."""
    import time

    from .io.trajectory import load_trajectory
    from .render.offscreen import RenderOptions
    from .render.video import render_trajectory
    from .runner import run_scene
    from .scene import Scene

    t0 = time.perf_counter()
    out_dir = Path(out_dir)
    scene = Scene.from_dict(DEMO_SCENE, name="demo")
    body, skin = build_demo_body()
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
