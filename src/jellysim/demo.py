"""``jellysim demo``: a fluted gelatin jelly slid onto a plate at 0.7 m/s from 1 cm
(``--scene cow``: Spot the cow, shipped in ``jellysim/data``, dropped on it).

Everything physical about the demo lives in :data:`DEMO_SCENE` (a scene dictionary in the
format of :mod:`jellysim.scene`; its ``[body]`` table is unused because the body comes from
:func:`build_demo_body`) and the shapes in :data:`DEMO_SHAPES`.
"""
from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np

from .params import REPORT_DENSITY
from .errors import BuildError, JellysimError, RunInterrupted
from .skin import bind_body_skin
from .io.trajectory import load_trajectory
from .render.offscreen import RenderOptions
from .render.video import render_trajectory
from .runner import holds_unfinished_run, prepare_out_dir, run_scene
from .io.usd import export_usd
from .io.checkpoint import CHECKPOINT

__all__ = ["DEMO_SCENE", "DEMO_SHAPE", "DEMO_SHAPES", "build_demo_body", "demo_mesh",
           "run_demo"]

DEMO_SHAPES = {
    "jelly": {
        "mesh": "mould",        # jellysim.geometry.shapes.jelly_mould: 8.7 cm wide, 5 cm tall
        "length": 0.087,        # [m] largest extent
        "drop_height": 0.01,    # [m] gap between the jello and the plate at t = 0
        # [m/s] slid onto the plate: it lands, sticks, sways (half-period peaks 17.5, 11.3,
        # 6.1, 3.7, 1.7, 1.6 mm: 4 periods above 1 mm; tossed at 0.5 m/s from 3 cm: 2)
        "velocity": [0.7, 0.0, 0.0],
        "points": 1500,         # grid nodes (marching grid warped onto the surface)
        "connect": "marching",
        "seed": 7,
    },
    "cow": {
        "mesh": "spot",         # Spot the cow (public domain, Keenan Crane), data/spot.obj
        "length": 0.10,
        # set down on the plate (1 mm gap): dropped even 5 mm, its legs buckle (Euler load,
        # README "Physical jello from Python") and it falls over
        "drop_height": 0.001,
        "velocity": [0.0, 0.0, 0.0],
        "points": 3000,
        "connect": "marching",
        "seed": 7,
        # firm gelatin (examples/spot_drop.toml): at the dessert preset's 10 kPa a 10 cm cow's
        # 1 cm legs carry ~6 kPa and it slumps to half its height (README, tests/test_bunny.py)
        "material": {"youngs_modulus": 1.0e5},
    },
    "mesh": {
        "mesh": "file",         # the user's own (jellysim demo --mesh PATH)
        "length": 0.10,
        "drop_height": 0.01,    # dropped 1 cm onto the plate
        "velocity": [0.0, 0.0, 0.0],
        "points": 2000,
        "connect": "marching",
        "seed": 7,
    },
}
"""Geometry of the demo bodies (built by :func:`jellysim.build.build_body`)."""
DEMO_SHAPE = DEMO_SHAPES["jelly"]

DEMO_SCENE = {
    # unused by the demo (its body comes from build_demo_body), required by the scene format
    "body": {"type": "box", "points": 2},
    "springs": {"radius": 1.0},
    # real dessert gelatin (the preset: 1141 kg/m^3, E = 10 kPa, Poisson's ratio 0.48, damping
    # ratio 0.02 at 5 Hz; Stable Neo-Hookean tets), the contact ground (restitution 0.3,
    # Coulomb friction 0.6), symplectic substeps chosen from the stability estimate
    "material": {"preset": "gelatin"},
    # a wet plate: set gelatin sticks to it (no slip: a touching point does not move along
    # the plate; with Coulomb friction alone, 1.5, a tossed jelly's base slides and re-lands
    # as it lands and the sway dies in ~0.5 s; held, it sways for ~4 periods, BENCHMARKS.md
    # "Session 8")
    "ground": {"friction": 1.5, "no_slip": True},
    "integrator": {"dt": 1.0 / 60.0, "steps": 180},
    "output": {"every": 1, "vtu": False},
}
"""Physical settings of the demo (scene format): 3 s simulated, 60 frames per second."""


def demo_mesh(name: str = "jelly", mesh=None, up: str = "y", texture: bool = False):
    """The demo's surface: vertices [m] (m, 3), faces (f, 3), scaled to the shape's
    ``length``, standing ``drop_height`` above y = 0, centred in x and z.  ``name = "mesh"``:
    the surface of the file ``mesh`` (any format :func:`~jellysim.geometry.load_mesh`
    reads), its ``up`` axis turned to +y and its faces outward.  ``texture``: also return the
    file's texture coordinates per face corner (f, 3, 2) and its faces' materials (``None``
    for the shipped shapes)."""
    shape, corner_uv, materials = DEMO_SHAPES[name], None, None
    if shape["mesh"] == "file":
        from .geometry.mesh import load_mesh, outward, rotate_up

        m = outward(load_mesh(mesh), str(mesh))
        v, f, corner_uv, materials = rotate_up(m.vertices, up), m.faces, m.uv, m.materials
    elif shape["mesh"] == "mould":
        from .geometry.shapes import jelly_mould

        v, f = jelly_mould()
    else:
        from ._interrupts import import_trimesh

        trimesh = import_trimesh()
        with resources.as_file(resources.files("jellysim") / "data" / "spot.obj") as p:
            mesh = trimesh.load(p, process=False, force="mesh")
        mesh.merge_vertices(merge_tex=True, merge_norm=True)
        v, f = np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces)
    v = v * (shape["length"] / np.ptp(v, axis=0).max())
    lo, hi = v.min(axis=0), v.max(axis=0)
    v = v - [0.5 * (lo[0] + hi[0]), lo[1] - shape["drop_height"], 0.5 * (lo[2] + hi[2])]
    return (v, np.asarray(f, dtype=np.int64)) + ((corner_uv, materials) if texture else ())


def build_demo_body(name: str = "jelly", points: int | None = None, mesh=None,
                    up: str = "y"):
    """The demo's jello body and its skin: ``(Body, Skin)``: the surface filled with a
    marching grid (warped onto the surface) by :func:`jellysim.build.build_body`,
    the skin the surface itself bound to the body's tets.  ``points``: grid points inside
    (default ``DEMO_SHAPES[name]["points"]``)."""
    import warnings

    from .build import build_body
    from .geometry.mesh import Mesh

    shape = DEMO_SHAPES[name]
    verts, faces, uv, materials = demo_mesh(name, mesh, up, texture=True)
    with warnings.catch_warnings():
        # the shipped surfaces are clean; a user's mesh is reported (demo --mesh)
        warnings.simplefilter("default" if mesh is not None else "ignore")
        surface = Mesh.from_arrays(verts, faces, name=str(mesh or f"{name}.obj"))
        if mesh is not None:  # (named by its file in what the build says)
            from dataclasses import replace

            surface = replace(surface, path=Path(mesh))
        body = build_body(surface,
                          points=shape["points"] if points is None else int(points),
                          connect=shape["connect"], density=REPORT_DENSITY,
                          seed=shape["seed"])
    body.meta.update(builder=f"demo-{name}", **{k: v for k, v in shape.items()})
    return body, bind_body_skin(body, verts, faces, uv, materials)


def demo_command(out_dir, scene, mesh, up, points, frames, usd, backend=None, device=None,
                 precision=None) -> str:
    """The ``jellysim demo ... --resume`` command that continues a demo made with these
    options (a shell line)."""
    import shlex

    opts = [("--out", out_dir), ("--scene", None if scene == "jelly" else scene),
            ("--mesh", mesh), ("--up", None if mesh is None or up == "y" else up),
            ("--points", points), ("--frames", frames), ("--backend", backend),
            ("--device", device), ("--precision", precision)]
    return ("jellysim demo" + "".join(f" {k} {shlex.quote(str(v))}" for k, v in opts
                                      if v is not None)
            + ("" if usd else " --no-usd") + " --resume")


def _rendering_left(run_dir: Path, scene, steps: int):
    """The finished run of a demo stopped while rendering, as :func:`run_scene` returns one,
    when it is this demo's (same scene and length); else a :class:`JellysimError`."""
    from .runner import RunResult, _asked_text

    path = run_dir / "trajectory.npz"
    traj = load_trajectory(path, mmap=True)
    done = int(traj.steps[-1])
    if traj.scene_toml != _asked_text(scene, steps) or done != steps:
        raise JellysimError(f"--resume: {run_dir} holds a demo made with other options (scene "
                            "or --frames); give the options it was made with, or --overwrite")
    return RunResult(out_dir=run_dir, trajectory=path, pvd=None, frames=traj.frame_count,
                     steps=done, seconds=0.0, resumed_from=done)


def _drop_stale(old, run_dir: Path) -> None:
    """An earlier demo's video and USD go once a new demo's run has started in ``run_dir``
    (they no longer match the run beside them); kept when it never started."""
    if holds_unfinished_run(run_dir):
        for p in old:
            p.unlink(missing_ok=True)


def run_demo(out_dir="out", *, frames: int | None = None, size=(960, 540), usd: bool = True,
             progress: bool = True, vtu: bool = False, scene: str = "jelly",
             backend: str | None = None, device: str | None = None,
             precision: str | None = None, threads: int | None = None,
             overwrite: bool = False, points: int | None = None, mesh=None,
             up: str = "y", resume: bool = False) -> dict:
    """Simulate a demo scene (``"jelly"``: a fluted gelatin mould slid onto a plate at 0.7 m/s
    from 1 cm; ``"cow"``: Spot, in firm gelatin, set down on it) and write ``<out_dir>/demo.mp4`` (+
    ``demo.usdc``; the cow: ``demo_cow.*``); the run itself goes to ``<out_dir>/demo/``
    (``demo_cow/``).  ``frames``: simulate only the first ``frames`` frames (a quick run, CI).
    ``backend``/``device``/``precision`` override the scene's (refused with a
    :class:`~jellysim.errors.SceneError` where the backend lacks the demo's physical path);
    ``threads``: numba threads (default: by problem size).  An earlier demo's outputs there
    are refused (:class:`~jellysim.errors.JellysimError`) unless ``overwrite``, which
    replaces them once the new demo runs (a demo that fails before it starts keeps them; one
    stopped after it started leaves only its own partial run, no older video or USD beside
    it).  ``resume``: continue the interrupted demo in ``out_dir`` (Ctrl-C, a kill; give the
    same options), then render it.  ``points``: see :func:`build_demo_body`.  ``mesh``: a surface mesh
    file of one's own instead, scaled to 10 cm, its ``up`` axis turned up, dropped 1 cm onto
    the plate in dessert gelatin (writes ``demo_<its name>.*``).  Returns the paths written
    and timings [s]."""
    import time

    from .scene import Scene


    t0 = time.perf_counter()
    out_dir = Path(out_dir)
    if mesh is not None:
        if scene != "jelly":
            raise JellysimError(f"--mesh {mesh} and --scene {scene}: the mesh is the demo's "
                                "body; give one of them")
        if not Path(mesh).is_file():
            raise JellysimError(f"--mesh {mesh}: no such file")
        scene = "mesh"
    if scene not in DEMO_SHAPES or scene == "mesh" and mesh is None:
        raise JellysimError(f"unknown demo scene {scene!r}; choose one of 'jelly', 'cow' "
                            "(or --mesh PATH)")
    own = Path(mesh).stem if mesh is not None else None
    stem = ("demo" if scene == "jelly" else f"demo_{scene}" if own is None else
            f"demo_mesh_{own}" if own in DEMO_SHAPES else f"demo_{own}")  # (not Spot's)
    old = [out_dir / f"{stem}.mp4", out_dir / f"{stem}.usdc"]
    again = demo_command(out_dir, scene if mesh is None else "jelly", mesh, up, points, frames,
                         usd, backend, device, precision)
    run_dir = out_dir / stem
    interrupted = holds_unfinished_run(run_dir)
    # a demo stopped while rendering: its run is whole, its video (or USD) was never written
    unrendered = (not interrupted and (run_dir / "trajectory.npz").is_file()
                  and not (old[0].exists() and (old[1].exists() or not usd)))
    if resume and overwrite:
        raise JellysimError("--resume and --overwrite: give one (--overwrite starts afresh)")
    if resume and not interrupted and not unrendered:
        raise JellysimError(f"--resume: {run_dir} holds no interrupted demo to continue (no "
                            f"{CHECKPOINT}, and its video is there); run it without --resume")
    if not resume and not overwrite and unrendered:
        raise JellysimError(f"--out {out_dir}: holds a demo simulated but not rendered "
                            f"({run_dir}: stopped while rendering?); finish it with: {again}, "
                            "or pass --overwrite to start afresh, or choose another --out")
    if not resume and not overwrite and interrupted:
        raise JellysimError(f"--out {out_dir}: holds an interrupted demo ({run_dir}); continue "
                            f"it with: {again}, or pass --overwrite to start afresh (its "
                            "frames so far are lost), or choose another --out")
    if not overwrite and not resume and any(p.exists() for p in old):
        raise JellysimError(f"--out {out_dir}: holds an earlier demo "
                            f"({', '.join(p.name for p in old if p.exists())}); pass "
                            "--overwrite to replace it, or choose another --out")
    shape = DEMO_SHAPES[scene]
    raw = dict(DEMO_SCENE, body=dict(DEMO_SCENE["body"], velocity=shape["velocity"]),
               material=dict(DEMO_SCENE["material"], **shape.get("material", {})))
    sc = Scene.from_dict(raw, name="demo").with_backend(backend, device, precision)
    sc.text = (f"# jellysim demo --scene {scene}: the body is the demo's own "
               f"(jellysim.demo.build_demo_body('{scene}'"
               + (f", mesh={str(mesh)!r}, up={up!r}" if mesh is not None else "")
               + "), not [body] below\n" + sc.text)
    if threads is not None:
        sc.params["integrator"]["threads"] = int(threads)
    from . import _warmup  # a first run: the step compiles beside the body's sampling

    _warmup.start(sc.params)
    try:
        body, skin = build_demo_body(scene, points, mesh, up)
    except BuildError as exc:  # (its fixes name build options: the demo's is --points)
        what = f"--mesh {mesh}" if mesh is not None else f"--scene {scene}"
        said = str(exc)  # (without the builder's own naming of the file: --mesh names it)
        if mesh is not None and said.partition(": ")[0].endswith(Path(str(mesh)).name):
            said = said.partition(": ")[2]
        raise BuildError(f"{what}: {said} (demo: a larger --points gives a finer grid)"
                         ) from None
    # only checked here: run_scene deletes an earlier demo run once this one can start, and
    # the video and USD below replace the old ones atomically (a failed demo keeps them)
    if not resume:
        prepare_out_dir(run_dir, overwrite=overwrite, delete=False)
    steps = sc.steps if frames is None else max(1, int(frames) - 1) * sc.frame_every
    try:
        result = (_rendering_left(run_dir, sc, steps) if unrendered and resume else
                  run_scene(sc, run_dir, progress=progress, vtu=vtu, steps=steps,
                            skin=skin, body=body, overwrite=overwrite, resume=resume))
    except RunInterrupted as exc:
        _drop_stale(old, run_dir)
        said = str(exc).split("; continue with: ")[0]
        raise RunInterrupted(f"{said}; continue with: {again}", step=exc.step,
                             signal=exc.signal, out_dir=exc.out_dir) from None
    except BaseException:
        if overwrite:
            _drop_stale(old, run_dir)
        raise
    t_sim = time.perf_counter()
    traj = load_trajectory(result.trajectory)
    written = {"trajectory": result.trajectory}
    try:  # (each file goes to a temporary name first: a stopped one leaves none)
        written["video"] = render_trajectory(traj, out_dir / f"{stem}.mp4",
                                             RenderOptions(size=size, plate=True,
                                                           opacity=0.85), progress=progress,
                                             overwrite=True)  # (the demo's own checks: above)
        t_render = time.perf_counter()
        if usd:
            written["usd"] = export_usd(traj, out_dir / f"{stem}.usdc", overwrite=True)
    except KeyboardInterrupt:
        for path, key in zip(old, ("video", "usd")):  # an earlier demo's: they no longer
            if key not in written:                    # match the run beside them
                path.unlink(missing_ok=True)
        import signal

        raise RunInterrupted(f"interrupted while rendering: the simulation is complete in "
                             f"{run_dir}; make the video with: {again}", step=int(traj.steps[-1]),
                             signal=signal.SIGINT, out_dir=run_dir) from None
    if not usd:  # an earlier demo's USD would no longer match this one's video
        old[1].unlink(missing_ok=True)
    written["seconds"] = {"simulate": t_sim - t0, "render": t_render - t_sim,
                          "total": time.perf_counter() - t0,
                          "startup": result.startup_seconds()}
    written["reused"] = bool(unrendered and resume)  # (only the rendering was left)
    written["points"] = body.point_count
    written["springs"] = body.spring_count
    written["frames"] = traj.frame_count
    return written
