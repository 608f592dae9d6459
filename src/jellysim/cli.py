"""Command line: ``jellysim run scene.toml --out DIR`` and friends."""
from __future__ import annotations

import sys
import time

import click

from .errors import JellysimError, NothingToResume, RunInterrupted
from .kernels import Backend
from .params import REPORT_DENSITY


def _fail(message: str) -> None:
    click.secho(f"error: {message}", fg="red", err=True)
    sys.exit(2)


_max_memory = click.option(
    "--max-memory", default=None, metavar="SIZE",
    help="Refuse to build a body whose memory estimate exceeds SIZE (e.g. 4G; default: the "
         "memory available). Sets JELLYSIM_MAX_MEMORY.")


def _set_max_memory(value) -> None:
    import os

    if value is None:
        return

    try:
        os.environ["JELLYSIM_MAX_MEMORY"] = str(parse_size(value))
    except ValueError as exc:
        _fail(f"--max-memory: {exc}")


_WRITERS = ("build", "render", "export", "plot")
"""Commands whose output files are written whole or not at all (a Ctrl-C says so)."""


class _Group(click.Group):
    """Any jellysim error or file-system error that a command did not report itself becomes
    one ``error:`` line (exit code 2), never a traceback."""

    def invoke(self, ctx):
        import warnings

        SAID.clear()  # a command's warnings: "warning: ..." once each, not Python's form

        def show(message, category, filename, lineno, file=None, line=None):
            say_once(str(message))

        try:
            with warnings.catch_warnings():
                warnings.showwarning = show
                return super().invoke(ctx)
        except JellysimError as exc:
            _fail(str(exc))
        except KeyboardInterrupt:
            if ctx.invoked_subcommand not in _WRITERS:  # (was click's bare "Aborted!", exit 1)
                click.secho(f"interrupted: {ctx.invoked_subcommand or 'jellysim'} stopped",
                            fg="yellow", err=True)
                sys.exit(130)
            # their outputs go to a temporary name (or a staging folder) and are renamed
            # only when complete: an interrupted one leaves what was there before
            click.secho(f"interrupted: {ctx.invoked_subcommand} stopped; nothing half-written "
                        "was kept (an earlier output of the same name is as it was)",
                        fg="yellow", err=True)
            sys.exit(130)
        except BrokenPipeError:  # `jellysim inspect ... | head`: the reader has gone
            import os

            try:  # (quietly: no "error: Broken pipe", nor one more at the exit's flush)
                os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            except (OSError, ValueError):
                pass
            sys.exit(141)  # (128 + SIGPIPE, as a shell's own tools end)
        except OSError as exc:
            from .io.atomic import describe_os_error

            _fail(describe_os_error(exc))


@click.group(cls=_Group)
@click.version_option(package_name="jellysim")
def cli() -> None:
    """jellysim: soft, wobbly bodies as 3D mass-spring networks."""
    import signal
    import threading

    if threading.current_thread() is threading.main_thread():
        # SIGTERM (a `timeout`, a job scheduler) stops a command as Ctrl-C does, so its
        # half-written outputs are cleaned up (`run` saves a checkpoint: runner.py)
        signal.signal(signal.SIGTERM, _terminate)


def _terminate(signum, frame):
    raise KeyboardInterrupt


@cli.command()
@click.argument("scene_file", type=click.Path(dir_okay=False), required=False)
@click.option("-o", "--out", "out_dir", type=click.Path(file_okay=False), default=None,
              help="Output directory (default: out/<scene name>).")
@click.option("--steps", type=click.IntRange(min=1), default=None,
              help="Override the scene's step count (e.g. a quick test run).")
@click.option("--no-vtu", is_flag=True, help="Skip the ParaView .pvd/.vtu series.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@click.option("--video", type=click.Path(dir_okay=False), default=None,
              help="Also render the run to this .mp4/.gif (see 'jellysim render').")
@click.option("--usd", type=click.Path(dir_okay=False), default=None,
              help="Also export the skin to this .usdc (see 'jellysim export').")
@click.option("--glb", type=click.Path(dir_okay=False), default=None,
              help="Also export the skin to this glTF .glb.")
@click.option("--partition", type=click.Choice(["morton", "metis"]), default="morton",
              show_default=True, help="Under mpiexec: how points are split among ranks.")
@click.option("--backend", type=click.Choice([b.value for b in Backend]), default=None,
              help="Override the scene's [integrator] backend (warp: pip install "
                   "'jellysim[gpu]').")
@click.option("--device", default=None,
              help="Warp device: auto (a GPU when present), cpu, cuda, cuda:N.")
@click.option("--precision", type=click.Choice(["float64", "float32"]), default=None,
              help="float64 or float32 (warp; numba explicit step).")
@click.option("--threads", type=click.IntRange(min=1), default=None,
              help="Numba threads (overrides the scene's [integrator] threads; default: 1 and "
                   "all are timed as the run goes, the faster kept, one on a tie).  Results "
                   "do not depend on it.")
@click.option("--overwrite", is_flag=True,
              help="Reuse a non-empty output folder: the earlier run's files in it "
                   "(trajectory.npz, *.pvd, *.vtu) are deleted first.")
@click.option("--set", "settings", multiple=True, metavar="SECTION.KEY=VALUE",
              help="Override one scene value (TOML syntax), e.g. --set body.points=500 "
                   "--set 'material.preset=\"gelatin\"'; --set obstacle.2.friction=0.9 sets "
                   "the second [[obstacle]] table's.  Repeatable.")
@click.option("--resume", "resume_dir", type=click.Path(file_okay=False), default=None,
              help="Continue the interrupted run in this output directory from its last "
                   "checkpoint (same scene file; bit-identical to an uninterrupted run), or "
                   "extend a finished one given more steps (--steps N).")
@click.option("--checkpoint-every", type=click.IntRange(min=0), default=None,
              help="Steps between checkpoints (0: only when interrupted; default: the "
                   "scene's [output] checkpoint_every, else about once a minute).")
@_max_memory
def run(scene_file, out_dir, steps, no_vtu, quiet, video=None, usd=None, glb=None,
        partition="morton", backend=None, device=None, precision=None, threads=None,
        overwrite=False, settings=(), resume_dir=None, checkpoint_every=None,
        max_memory=None) -> None:
    """Simulate SCENE_FILE (TOML) and write trajectory.npz and body.pvd (under
    'mpiexec -n N': on N ranks, docs/mpi.md).  `jellysim run --resume DIR` continues a run
    without its scene file (the run's checkpoint records the scene).

    Frames are streamed to OUT/trajectory.stream while the run goes; Ctrl-C (SIGINT) or
    SIGTERM finishes the current frame, saves a checkpoint and says how to --resume."""
    from pathlib import Path

    from .cli_visual import check_run_outputs

    for given, flag in ((out_dir, "--out"), (resume_dir, "--resume")):
        if given is not None and not str(given).strip():
            _fail(f"{flag} is empty: give a folder name (without {flag}: out/<scene name>)")
    if scene_file is None and resume_dir is None:
        _fail("missing SCENE_FILE: give a scene (TOML; `jellysim scene-help` lists its keys, "
              "examples/ has some), or --resume DIR to continue a run")
    if resume_dir is not None and overwrite:  # (--overwrite was ignored: the reliability trial)
        _fail(f"--resume {resume_dir} continues the run there, --overwrite would start it "
              "afresh: give one of them")
    try:
        check_run_outputs(video=video, usd=usd, glb=glb, overwrite=overwrite)
    except JellysimError as exc:
        _fail(str(exc))
    say = say_once  # (each warning once per command)

    def load():
        import warnings

        from .scene import Scene

        with warnings.catch_warnings(record=True) as caught:  # said once, as the run's are
            warnings.simplefilter("always")
            try:
                if scene_file is None:  # (the run's checkpoint records its scene)
                    from .io.checkpoint import scene_of_run

                    scene = scene_of_run(resume_dir, overrides=settings)
                else:
                    scene = Scene.load(scene_file, overrides=settings)
            except JellysimError as exc:  # --steps stands for a missing [integrator] steps
                if steps is None or "missing value 'steps'" not in str(exc):
                    raise
                scene = Scene.load(scene_file, overrides=(*settings,
                                                          f"integrator.steps={steps}"))
        for w in caught:
            say(str(w.message))
        scene = scene.with_backend(backend, device, precision)
        if threads is not None:
            scene.params["integrator"]["threads"] = threads
        return scene

    _set_max_memory(max_memory)
    if launched_under_mpi():
        def load_distributed():  # (an error here is printed once, by rank 0)
            for given, flag in ((resume_dir, "--resume"),
                                (checkpoint_every, "--checkpoint-every")):
                if given is not None:
                    raise JellysimError(f"{flag}: checkpoints and resuming are not done under "
                                        "mpiexec yet (docs/mpi.md); run without mpiexec, or "
                                        f"without {flag}")
            return load()

        return cli_run(scene_file, out_dir, steps=steps, no_vtu=no_vtu, quiet=quiet,
                       partition=partition, video=video, usd=usd, glb=glb,
                       overwrite=overwrite, say=say, load=load_distributed)

    out, fresh = None, False
    if partition != "morton":  # (the serial run has no ranks to split among)
        say(f"--partition {partition} applies under mpiexec only: this serial run ignores it")
    try:
        scene = load()
        if resume_dir and out_dir and Path(out_dir) != Path(resume_dir):
            raise JellysimError(f"--resume {resume_dir} and --out {out_dir} differ: a run "
                                "resumes in its own directory (give only --resume)")
        out = (Path(resume_dir) if resume_dir else Path(out_dir) if out_dir
               else Path("out") / Path(scene_file).stem)
        fresh = not out.exists()
        if not resume_dir:
            prepare_out_dir(out, overwrite=overwrite, delete=False)  # (run_scene deletes
        began = time.perf_counter()
        result = run_scene(scene, out, progress=not quiet, vtu=False if no_vtu else None,
                           overwrite=overwrite,  # an earlier run once the new one can start)
                           steps=steps, resume=resume_dir is not None,
                           checkpoint_every=checkpoint_every, notify=say)
    except NothingToResume as exc:
        click.echo(str(exc))  # a finished run and no more steps asked: not a failure
        return
    except RunInterrupted as exc:
        # the printed resume command ends the message: it keeps this run's --no-vtu and
        # outputs (the step count is in the checkpoint)
        import shlex

        if overwrite:  # an earlier run's video/USD/glTF no longer match the run beside them
            for path in (video, usd, glb):
                if path and Path(path).is_file():
                    Path(path).unlink()

        extra = "".join(f" {flag} {shlex.quote(str(v))}" for flag, v in
                        (("--video", video), ("--usd", usd), ("--glb", glb)) if v)
        click.secho(str(exc) + (" --no-vtu" if no_vtu else "") + extra, fg="yellow", err=True)
        sys.exit(128 + exc.signal if exc.signal else 3)
    except (JellysimError, KeyboardInterrupt) as exc:
        if fresh and out.is_dir() and not any(out.iterdir()):
            out.rmdir()  # refused (or stopped) before anything was written: no empty folder
        if isinstance(exc, KeyboardInterrupt):  # while the body was built, or a second
            import shlex                         # Ctrl-C that stopped the stepping at once

            from .runner import holds_unfinished_run

            if out is not None and out.is_dir() and holds_unfinished_run(out):
                click.secho(f"interrupted: run stopped at once; its frames so far are in {out}"
                            "; continue with: jellysim run "
                            + ("" if scene_file is None else f"{shlex.quote(str(scene_file))} ")
                            + f"--resume {shlex.quote(str(out))}", fg="yellow", err=True)
            else:
                click.secho("interrupted: run stopped before its first step; nothing was "
                            "written" + ("" if fresh else " (what the folder held is as it "
                                                          "was)"), fg="yellow", err=True)
            sys.exit(130)
        for w in getattr(exc, "run_warnings", ()):
            say(w)
        _fail(str(exc))
    if result.resumed_from is not None:
        click.echo(f"resumed from the checkpoint at step {result.resumed_from}")
    for w in result.warnings:
        say(w)
    taken = result.steps - (result.resumed_from or 0)
    rate = taken / result.seconds if result.seconds > 0 else float("inf")
    realtime = (f", {result.simulated / result.seconds:.2g}x real time"
                if result.seconds > 0 and result.simulated > 0 else "")
    wall = time.perf_counter() - began  # (the summary's seconds are the stepping's alone)
    used = sorted(result.thread_steps.items())
    threads = "" if not used else f", on {used[0][0]} thread(s)" if len(used) == 1 else (
        ", on " + " / ".join(f"{c} thread(s) {100 * n / sum(k for _, k in used):.0f} %"
                             for c, n in used) + " of the steps (chosen by timing)")
    click.echo(f"{taken} steps, {result.frames} frames in {result.seconds:.3g} s "
               f"({_rate(rate)} steps/s{realtime}{threads})" + (
                   f"; {wall:.3g} s in all, with building the body and writing the frames"
                   if wall - result.seconds > max(1.0, 0.25 * wall) else ""))
    startup = result.startup_seconds()
    if startup > 1.0 and startup > 0.3 * result.seconds:  # numba compiling on a first run
        pace = result.seconds - startup
        click.echo(f"  of which {startup:.3g} s were the first steps' start-up (loading the "
                   f"compiled kernels, or compiling them on a first run): "
                   f"{_rate(taken / pace)} steps/s, {result.simulated / pace:.2g}x real time "
                   "without it")
    from .cli_visual import echo_run_outputs

    echo_run_outputs(result, _fail, video=video, usd=usd, glb=glb, quiet=quiet)


@cli.command()
@click.argument("mesh_file", type=click.Path(dir_okay=False))
@click.option("-o", "--out", "out_file", type=click.Path(dir_okay=False), required=True,
              help="Body file to write (.jello text or .npz).")
@click.option("--points", type=click.IntRange(min=4), default=5000, show_default=True,
              help="Points to sample inside (a target for marching/tetgen).")
@click.option("--connect", type=click.Choice(["radius", "marching", "delaunay", "tetgen"]),
              default=None,
              help="Builder: marching (the default: a grid warped onto the surface, with "
                   "tets: the physical path's best-shaped body, as Body.from_mesh), delaunay, "
                   "tetgen, or radius (the report's random points and radius springs; the "
                   "default when --radius is given).")
@click.option("--sampling", type=click.Choice(["uniform", "edge", "grid", "poisson"]),
              default="uniform", show_default=True, help="How points are placed inside.")
@click.option("--radius", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Connection radius [m] for radius springs (default: from --neighbours).")
@click.option("--neighbours", type=click.FloatRange(min=1), default=24.0, show_default=True,
              help="Target mean neighbour count when --radius is not given.")
@click.option("--h", "h", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Cube edge [m] of the marching grid.")
@click.option("--snap/--no-snap", default=True, show_default=True,
              help="marching: warp the grid onto the surface so the body fills the mesh; "
                   "--no-snap keeps the report's staircase (the grid's tets wholly inside).")
@click.option("--surface-vertices/--no-surface-vertices", default=None,
              help="Add the mesh vertices to the points (default: on for delaunay).")
@click.option("--surface-samples/--no-surface-samples", default=None,
              help="delaunay and radius: also put points on the surface's sharp edges and "
                   "faces at the point spacing, so the body has flat faces to rest on "
                   "(default: on, as Body.from_mesh; off: delaunay with the sampled points "
                   "and the mesh vertices, radius with exactly --points points inside, as the "
                   "report).")
@click.option("--relax", type=click.IntRange(min=0), default=None,
              help="delaunay: Lloyd passes of the interior points before the "
                   "tetrahedralization (default: 10 with surface samples; 0 is the report's "
                   "random points).")
@click.option("--epsilon", type=click.FloatRange(min=0), default=None,
              help="delaunay: of two points closer than EPSILON [m] the later is removed "
                   "before the tetrahedralization (the report's near-duplicate removal; "
                   "default: 1 % of the median nearest-neighbour distance).")
@click.option("--density", type=click.FloatRange(min=0, min_open=True), default=REPORT_DENSITY,
              show_default=True, help="Density [kg/m^3].")
@click.option("--rule", type=click.Choice(["auto", "parity", "winding"]), default="auto",
              show_default=True, help="Inside rule: parity (overlapping shells leave the "
              "overlap hollow), winding (overlapping shells are one solid), auto (parity when "
              "closed).")
@click.option("--size", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Scale the mesh so its largest extent is SIZE metres (default: its "
                   "coordinates are read as metres).")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True)
@click.option("--up", type=click.Choice(["y", "z", "x", "-y", "-z", "-x"]), default="y",
              show_default=True, help="The mesh's axis that points up (z for most CAD and "
              "STL files): turned to +y, jellysim's up.")
@_max_memory
@click.option("--overwrite", is_flag=True, help="Replace OUT_FILE if it exists.")
def build(mesh_file, out_file, points, connect, sampling, radius, neighbours, h, snap,
          surface_vertices, surface_samples, relax, density, size, seed, up="y",
          max_memory=None, overwrite=False, epsilon=None, rule="auto") -> None:
    """Build a jello body from MESH_FILE and write it to a .jello or .npz file.

    The mesh's coordinates are read as metres unless --size scales it."""
    import warnings

    _set_max_memory(max_memory)

    from .build import body_stats, build_body
    from .geometry.jellyfile import write_body

    from pathlib import Path

    from .io.atomic import guard_file

    try:
        from .geometry.mesh import shipped

        if shipped(mesh_file).exists():  # else build_body names the missing mesh first
            guard_file(out_file, overwrite)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            if connect is None:
                connect = "radius" if radius is not None else "marching"
            if connect == "radius" and surface_samples is None:
                surface_samples = True  # jello defaults, as Body.from_mesh
            if epsilon is not None and connect != "delaunay":
                raise JellysimError(f"--epsilon is the near-duplicate distance of --connect "
                                    f"delaunay; --connect {connect} does not use it")
            body = build_body(mesh_file, points=points, connect=connect, sampling=sampling,
                              radius=radius, neighbours=neighbours, h=h,
                              surface_vertices=surface_vertices,
                              surface_samples=surface_samples, relax=relax, density=density,
                              seed=seed, size=size, snap=snap, up=up,
                              epsilon=epsilon, rule=rule)
            if getattr(body, "skin_vertices", None) is not None:  # as a run will bind it:
                from .skin import bind_body_skin  # says which parts the points cannot carry

                bind_body_skin(body, body.skin_vertices, body.skin_faces)
        write_body(out_file, body)
    except JellysimError as exc:
        _fail(str(exc))
    for w in caught:
        say_once(str(w.message))
    st = body_stats(body, density=density)
    extra = ""
    if body.meta.get("radius_chosen_for_neighbours"):
        extra = (f"; radius r = {body.meta['radius']:.4g} m chosen for "
                 f"{body.meta['radius_chosen_for_neighbours']:g} neighbours")
    if body.meta.get("surface_samples") and st["points"] > points:
        extra += (f"; {points} points sampled inside as asked (fewer where too near the "
                  "surface), the rest on the surface")
    held = ""
    if st["tet_volume"] is not None and st["volume"]:
        held = (f" (its tets hold {st['tet_volume']:.6g} m^3, "
                f"{100 * st['tet_volume'] / st['volume']:.0f} %: the physical path's mass is "
                f"{st['tet_mass']:.6g} kg)")
    click.echo(f"{st['points']} points, {st['springs']} springs, {st['tets']} tets, "
               f"volume {st['volume']:.6g} m^3, mass {st['mass']:.6g} kg{held}{extra}")
    click.echo(f"wrote {out_file}")


def _rate(r: float) -> str:
    """A rate for people: 12,345 / 18.2 / 0.0417 (a slow run's was "0 steps/s")."""
    return f"{r:,.0f}" if r >= 100 or r != r or r == float("inf") else f"{r:.3g}"


def _built(body) -> str:
    """``inspect``'s skin note for a body of points and springs alone: what a run builds."""
    from .skin import outer_skin

    skin = outer_skin(body)
    if skin is None:
        return (" (and a run builds none: its points enclose nothing, flat or fewer than 4, "
                "or no springs; it is drawn as points)")
    return (f" (a run builds one: the outer faces of the cells its springs hold, "
            f"{len(skin.faces)} triangles)")


def _skin_row(body) -> str:
    """``inspect``'s skin row for a body file: the mesh it was built from, and the skin a run
    carries when that mesh is coarser than the points (subdivided: its vertices first)."""
    from .skin import _fine_enough, body_tets

    v, f = body.skin_vertices, body.skin_faces
    uv = ", with its texture coordinates" if body.skin_uv is not None else ""
    if body.materials is not None:
        uv += ", materials " + ", ".join(map(repr, body.materials.names))
    row = f"{len(v)} vertices, {len(f)} faces{uv} (the mesh it was built from"
    fine_v, fine_f, _, _ = _fine_enough(v, f, body.points,
                                        body_tets(body.points, body.springs, body.tets))
    if len(fine_v) == len(v):
        return row + ": a run's skin)"
    return (row + f"; a run's skin subdivides it to the point spacing: {len(fine_v)} "
            f"vertices, {len(fine_f)} faces, the first {len(v)} those of the mesh)")


@cli.command()
@click.argument("path", type=click.Path())
@click.option("--set", "settings", multiple=True, metavar="SECTION.KEY=VALUE",
              help="A scene: override one value as `jellysim run --set` does.  Repeatable.")
def inspect(path, settings=()) -> None:
    """Describe a surface mesh (defects), a body file (.jello/.npz: counts and stats), a
    scene (.toml: the body it builds, its path, substeps, ground; nothing is run) or a run
    (its output folder or trajectory.npz: frames, status, centre of mass, energies, the
    smallest tet volume ratio)."""
    from pathlib import Path

    suffix = Path(path).suffix.lower()
    try:
        if _is_run(path):
            from .io.trajectory import load_trajectory
            from .trajectory_summary import trajectory_rows

            click.echo(f"{path}: run")
            for k, v in trajectory_rows(load_trajectory(path)):
                click.echo(f"  {k:<13} {v}")
            return
        if settings and suffix != ".toml":
            raise JellysimError(f"--set overrides a scene's values; {path} is not a scene "
                                "(.toml)")
        if suffix == ".toml":
            from .scene import Scene
            from .scene_summary import scene_summary

            said: list = []
            try:
                rows = scene_summary(Scene.load(path, overrides=settings), said)
            finally:
                for w in said:
                    say_once(str(w))
            click.echo(f"{path}: scene")
            for k, v in rows:
                click.echo(f"  {k:<12} {v}")
        elif suffix in (".jello", ".npz"):
            from .build import body_stats
            from .geometry.jellyfile import read_body

            body = read_body(path)
            st = body_stats(body)
            click.echo(f"{path}: body")
            skin = ("none in the file" + (
                " (a run shows the surface triangles)" if st["triangles"] else
                " (a run shows the outer faces of its tets)" if st["tets"] else _built(body))
                    if body.skin_vertices is None else _skin_row(body))
            rows = [
                ("points", st["points"]), ("springs", st["springs"]), ("tets", st["tets"]),
                ("surface triangles", st["triangles"]), ("skin", skin),
                ("springs per point", f"min {st['degree_min']}, mean {st['degree_mean']:.2f}, "
                                      f"max {st['degree_max']}"),
                ("rest length [m]", f"min {st['rest_length_min']:.4g}, mean "
                                    f"{st['rest_length_mean']:.4g}, max {st['rest_length_max']:.4g}"),
                ("volume [m^3]", "unknown" if st["volume"] is None else f"{st['volume']:.6g}"),
                ("mass [kg]", "unknown" if st["mass"] is None else f"{st['mass']:.6g}"),
                ("tets hold [m^3]", "-" if st["tet_volume"] is None else
                 f"{st['tet_volume']:.6g} (x {REPORT_DENSITY:g} kg/m^3 = {st['tet_mass']:.6g} "
                 "kg: the physical path's mass at that density)"),
                ("bounds [m]", " .. ".join("[" + ", ".join(f"{c:.6g}" for c in corner) + "]"
                                           for corner in st["bounds"])),
            ]
            for k, v in rows:
                click.echo(f"  {k:<20} {v}")
        else:
            import numpy as np

            from .geometry.mesh import load_mesh

            mesh = load_mesh(path)
            ext = np.ptp(mesh.vertices, axis=0)
            click.echo(f"{path}: surface mesh; coordinates are read as metres (jellysim build "
                       "--size S scales its largest extent to S m)")
            click.echo(f"extent [m]:              {ext[0]:.6g} x {ext[1]:.6g} x {ext[2]:.6g}")
            if not 1e-3 <= float(ext.max()) <= 10.0:
                click.secho(f"warning: {float(ext.max()):.4g} m across: if the mesh is in "
                            "millimetres or another unit, scale it (--size, [body] size = 0.1 "
                            "for 10 cm, size= in Python)", fg="yellow", err=True)
            click.echo(mesh.defects.describe())
            from .geometry.mesh import outward

            read = mesh.defects.volume
            mesh = outward(mesh, str(path))  # (as build does: said, via the CLI's warnings)
            if mesh.defects.volume != read:  # (else the two volumes below seemed to disagree)
                click.echo(f"volume, turned outward:  {mesh.defects.volume:.6g}")
            if mesh.defects.watertight:  # (one shell: does it pass through itself?)
                from .build import shell_overlap

                over, inside_vol, signed = shell_overlap(mesh)
                label = ("shells overlap/nest:    " if mesh.defects.shells > 1 else
                         "passes through itself:  ")
                click.echo(f"{label} {'yes' if over else 'no'} (inside-rule "
                           f"volume {inside_vol:.6g}, signed {signed:.6g}"
                           + ("; bodies take the inside rule's volume)" if over else ")"))
    except JellysimError as exc:
        _fail(str(exc))


def _is_run(path) -> bool:
    """A run's output folder, its trajectory stream, or a trajectory ``.npz``."""
    import zipfile
    from pathlib import Path

    p = Path(path)
    if p.is_dir():
        return True
    if p.suffix.lower() != ".npz" or not p.is_file():
        return False
    try:
        with zipfile.ZipFile(p) as z:
            names = set(z.namelist())
    except (OSError, zipfile.BadZipFile):
        return False
    return {"positions.npy", "times.npy"} <= names


@cli.command("scene-help")
def scene_help() -> None:
    """Print every scene key, its default and allowed range (Markdown)."""
    from .scene import schema_markdown

    click.echo(schema_markdown())


from .cli_visual import SAID, register, say_once; register(cli)  # noqa: E402,E702 (demo render...)
from .resources import parse_size
from .distributed.simulator import launched_under_mpi
from .runner import prepare_out_dir, run_scene
from .distributed.runner import cli_run


def main() -> None:
    cli()


if __name__ == "__main__":
    main()
