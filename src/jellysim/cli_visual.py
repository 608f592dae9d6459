"""Command line, visual side: ``demo``, ``render``, ``export``, ``view``, ``plot``.

Registered on the main group by :func:`register` (one line in :mod:`jellysim.cli`).  Every
command reads saved trajectories only; none of them changes a simulation.
"""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import click

from .errors import JellysimError, RunInterrupted
from .kernels import Backend
from .render.offscreen import RenderOptions
from .io.trajectory import load_trajectory
from .demo import run_demo
from .render.video import render_trajectory
from .viewer import view_trajectory
from .plot import plot_trajectory
from .io.usd import export_usd
from .io.gltf import export_glb
from .live import view_live
from .io.meshseq import export_mesh_sequence
from .io.vtk import export_pvd_file

__all__ = ["register", "write_run_outputs"]


def _fail(message: str) -> None:
    click.secho(f"error: {message}", fg="red", err=True)
    sys.exit(2)


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise click.BadParameter(f"'{text}' is not WIDTHxHEIGHT, e.g. 960x540") from None
    if w < 16 or h < 16:
        raise click.BadParameter("width and height must be at least 16 pixels")
    if w > MAX_SIDE or h > MAX_SIDE:
        raise click.BadParameter(f"width and height must be at most {MAX_SIDE} pixels "
                                 f"(the renderer's buffers), got {w}x{h}")
    return w, h


MAX_SIDE = 16384
"""Largest --size width or height [pixels] (100000x100000 aborted the renderer)."""


def _check_color(color: str) -> str:
    import pyvista

    try:
        pyvista.Color(color)
    except (ValueError, TypeError):
        raise click.BadParameter(f"'{color}' is not a colour: give a name (red, gold) or "
                                 "#rrggbb", param_hint="--color") from None
    return color


_camera = [
    click.option("--azimuth", type=click.FloatRange(-360, 360), default=None,
                 help="Camera azimuth in degrees around the vertical, from +x towards +z "
                      "(default 32)."),
    click.option("--elevation", type=click.FloatRange(-89, 90), default=None,
                 help="Camera elevation in degrees above the horizontal (default 20.4; 90: "
                      "from above)."),
    click.option("--zoom", type=click.FloatRange(0.1, 20), default=1.0, show_default=True,
                 help="Move the camera closer (> 1, centred on the body at the last frame, "
                      "or at --frame) or farther (< 1) than the framing that keeps the whole "
                      "motion in view.")]


def _camera_options(f):
    for opt in reversed(_camera):
        f = opt(f)
    return f


def _options(size, color, opacity, show, no_floor, camera=(None, None, 1.0)):
    show = {s.lower() for s in show}
    if "all" in show:
        show |= {"skin", "points", "springs"}
    return RenderOptions(size=_size(size), color=_check_color(color), opacity=opacity,
                         show_points="points" in show, show_springs="springs" in show,
                         show_skin="skin" in show or not show, floor=not no_floor,
                         azimuth=camera[0], elevation=camera[1], zoom=camera[2])


def _load(path):
    traj = load_trajectory(path)
    if traj.frame_count == 0:  # (a Recorder saved before any record())
        raise JellysimError(f"{path}: the trajectory holds no frame: nothing to show or "
                            "export (record at least one state before saving)")
    return traj


def _run_name(trajectory) -> str:
    """A run's name: its folder's (given the folder, its trajectory.npz or its stream)."""
    where = Path(trajectory)
    return (where if where.is_dir() and where.suffix != ".stream" else where.parent).name


def check_run_outputs(*, video=None, usd=None, glb=None, overwrite=False) -> None:
    """Before ``jellysim run`` simulates: the --video / --usd / --glb names have a known
    suffix and a folder that can be written (so a long run does not fail at its end)."""
    import os
    from pathlib import Path

    from .render.video import output_kind

    if video:
        output_kind(video)
    for path, suffixes, what in ((usd, (".usdc", ".usda", ".usd"), "--usd"),
                                 (glb, (".glb",), "--glb")):
        if path and Path(path).suffix.lower() not in suffixes:
            raise JellysimError(f"{what} {path}: the name must end in {' or '.join(suffixes)}")
    for path in (video, usd, glb):
        if not path:
            continue
        folder = Path(path).absolute().parent
        while not folder.exists() and folder != folder.parent:
            folder = folder.parent
        if not folder.is_dir() or not os.access(folder, os.W_OK | os.X_OK) or not _can_write(
                folder):
            raise JellysimError(f"cannot write {path}: {folder} is not a folder you can "
                                "write to")
        guard_output(path, overwrite)


def _can_write(folder) -> bool:
    """Whether a file can really be created in ``folder`` (permission bits do not say so for
    root, nor on special or read-only file systems): a probe file, removed at once."""
    import tempfile

    try:
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".jellysim-probe-"):
            return True
    except OSError:
        return False


def echo_run_outputs(result, fail, *, video=None, usd=None, glb=None, quiet=False) -> None:
    """The end of ``jellysim run`` (serial or under mpiexec): say what the run wrote, then
    render and export what was asked (:func:`write_run_outputs`); a refusal goes to ``fail``."""
    click.echo(f"wrote {result.trajectory}")
    if result.pvd:
        click.echo(f"wrote {result.pvd} (+ {result.frames} .vtu frames)")
    try:
        for p in write_run_outputs(result.trajectory, video=video, usd=usd, glb=glb,
                                   progress=not quiet):
            click.echo(f"wrote {p}")
    except JellysimError as exc:
        fail(str(exc))
    except KeyboardInterrupt:  # (the run itself is complete and saved: say how to finish)
        todo = [f"jellysim render {result.trajectory} -o {video}"] if video else []
        todo += [f"jellysim export {result.trajectory} -o {o}" for o in (usd, glb) if o]
        click.secho(f"interrupted while writing the run's outputs: the run is complete "
                    f"({result.trajectory}); nothing half-written was kept; write them with: "
                    + " and ".join(todo), fg="yellow", err=True)
        sys.exit(130)


def write_run_outputs(trajectory, *, video=None, usd=None, glb=None, progress=True):
    """After ``jellysim run``: render ``video`` and export ``usd`` / ``glb`` from the saved
    trajectory.  Returns the paths written."""
    out = []
    if not (video or usd or glb):
        return out
    traj = _load(trajectory)
    if video or usd or glb:
        _warn_inside_out(traj)
    if video:
        out.append(render_trajectory(traj, video, progress=progress,
                                     overwrite=True))  # (checked before the run)
    if usd:
        out.append(export_usd(traj, usd, overwrite=True))  # (checked before the run)
    if glb:
        out.append(export_glb(traj, glb, overwrite=True))
    return out


SAID: set = set()
"""The warnings the present command said (cleared as each command starts)."""


def say_once(message: str) -> None:
    """Say a warning on stderr, once per command."""
    if message not in SAID:
        SAID.add(message)
        click.secho(f"warning: {message}", fg="yellow", err=True)


def _warn_inside_out(traj) -> None:
    from .io.usd import inside_out_note

    note = inside_out_note(traj)
    if note:
        say_once(note)


_overwrite = click.option("--overwrite", is_flag=True,
                          help="Replace existing output files (and, for a folder of frames, "
                               "delete its old frames first); without it they are kept and "
                               "the command refuses.")


def guard_output(path, overwrite: bool) -> None:
    """Refuse (or with ``overwrite`` clear) what a render/export to ``path`` would replace."""
    from pathlib import Path

    from .io.atomic import guard_file, guard_folder
    from .render.video import output_kind

    path = Path(path)
    if path.suffix.lower() == ".pvd":  # its frames go into the sibling folder <stem>/
        guard_file(path, overwrite)
        guard_folder(path.parent / path.stem, [f"{path.stem}_[0-9]*.vtu"], overwrite)
    elif path.suffix.lower() in (".usdc", ".usda", ".usd", ".glb", ".csv"):
        guard_file(path, overwrite)
    elif output_kind(path) == "pngdir":
        guard_folder(path, ["frame_[0-9]*.png"], overwrite)
    else:
        guard_file(path, overwrite)


_show = click.option("--show", multiple=True,
                     type=click.Choice(["skin", "points", "springs", "all"],
                                       case_sensitive=False),
                     help="What to draw, instead of the default (the skin alone); repeatable: "
                          "'--show skin --show springs' draws both, '--show springs' only the "
                          "springs, 'all' everything.")
_size_opt = click.option("--size", default="960x540", show_default=True,
                         help="Image size WIDTHxHEIGHT in pixels.")
_size_render = click.option("--size", default="960x540", show_default=True,
                            help="Image size WIDTHxHEIGHT in pixels (runs side by side: "
                                 "each run's picture; they are put next to each other).")
_color = click.option("--color", default="#d81e3c", show_default=True,
                      help="Skin colour (name or #rrggbb).")
_opacity = click.option("--opacity", type=click.FloatRange(0.05, 1.0), default=0.7,
                        show_default=True, help="Skin opacity.")
_floor = click.option("--no-floor", is_flag=True, help="Do not draw the floor.")


@click.command()
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default="out",
              show_default=True, help="Output directory (writes demo.mp4, demo.usdc, demo/).")
@click.option("--frames", type=click.IntRange(min=2), default=None,
              help="Simulate only the first this many frames (1/60 s each; the full demo "
                   "has 181): a quick, shorter run, e.g. for CI.")
@_size_opt
@click.option("--no-usd", is_flag=True, help="Skip demo.usdc.")
@click.option("--quiet", is_flag=True, help="No progress bars.")
@click.option("--scene", type=click.Choice(["jelly", "cow"]), default="jelly",
              show_default=True,
              help="jelly: a fluted gelatin mould slid onto a plate (0.7 m/s from 1 cm); "
                   "cow: Spot (firm gelatin) set down on it (writes demo_cow.*).")
@click.option("--backend", type=click.Choice([b.value for b in Backend]), default=None,
              help="Kernels (default: the demo scene's, numba).")
@click.option("--device", default=None, help="Warp device: auto, cpu, cuda, cuda:N.")
@click.option("--precision", type=click.Choice(["float64", "float32"]), default=None,
              help="float64 or float32 (warp; numba explicit step).")
@click.option("--threads", type=click.IntRange(min=1), default=None,
              help="Numba threads (default: 1 and all are timed as the run goes, the faster "
                   "kept, one on a tie).")
@click.option("--overwrite", is_flag=True,
              help="Replace an earlier demo in OUT (its video, USD and run folder).")
@click.option("--points", type=click.IntRange(min=50), default=None,
              help="Grid points inside the shape (default 1500 jelly, 3000 cow, 2000 a "
                   "mesh; fewer: a quick, coarse run).")
@click.option("--mesh", type=click.Path(dir_okay=False), default=None,
              help="Your own surface mesh (OBJ, PLY, STL, ...) as the jello: scaled to 10 cm, "
                   "dropped 1 cm onto the plate in dessert gelatin (writes demo_<name>.*).")
@click.option("--up", type=click.Choice(["y", "z", "x", "-y", "-z", "-x"]), default="y",
              show_default=True, help="--mesh: its axis that points up (z for most CAD / "
              "STL files).")
@click.option("--resume", is_flag=True,
              help="Continue the demo in OUT that was interrupted (Ctrl-C, a kill) with the "
                   "same options, then render it.")
def demo(out_dir, frames, size, no_usd, quiet, scene, backend=None, device=None,
         precision=None, threads=None, overwrite=False, points=None, mesh=None, up="y",
         resume=False):
    """Real gelatin on a plate: writes OUT/demo.mp4 and OUT/demo.usdc (--mesh: your own
    shape as the jello)."""
    import warnings

    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            r = run_demo(out_dir, frames=frames, size=_size(size), usd=not no_usd,
                         progress=not quiet, scene=scene, backend=backend, device=device,
                         precision=precision, threads=threads, overwrite=overwrite,
                         points=points, mesh=mesh, up=up, resume=resume)
        for w in dict.fromkeys(str(w.message) for w in caught):
            say_once(w)
    except RunInterrupted as exc:  # (what was saved, and the command that continues it)
        click.secho(str(exc), fg="yellow", err=True)
        sys.exit(128 + exc.signal if exc.signal else 3)
    except JellysimError as exc:
        _fail(str(exc))
    s = r["seconds"]
    made = ("the earlier run's simulation reused" if r.get("reused") else
            f"body built and simulated in {s['simulate']:.1f} s")
    click.echo(f"{r['points']} points, {r['springs']} springs, {r['frames']} frames: "
               f"{made}, rendered in {s['render']:.1f} s, total {s['total']:.1f} s")
    if s.get("startup", 0.0) > 1.0:
        click.echo(f"  ({s['startup']:.1f} s of the simulating were the first steps' start-up: "
                   "loading the compiled kernels, or compiling them on a first run)")
    for key in ("video", "usd", "trajectory"):
        if key in r:
            click.echo(f"wrote {r[key]}")


@click.command()
@click.argument("trajectory", nargs=-1, required=True, type=click.Path())
@click.option("-o", "--output", required=True, type=click.Path(),
              help="video.mp4, anim.gif, picture.png or .jpg (last frame, or --frame) or a folder "
                   "(PNG frames).")
@_show
@_size_render
@click.option("--fps", type=click.FloatRange(min=0.1), default=None,
              help="Frames per second, each saved frame shown once (another rate than the "
                   "run's plays slower or faster, said; default: real time; a run saved "
                   "faster than 60 frames/s, 50 for a GIF, shows every k-th frame; a run "
                   "saved slower than 5 frames/s plays at 5).")
@_color
@_opacity
@_floor
@click.option("--frame", "frame", type=int, default=None,
              help="Render only this frame (e.g. -1 for the last).")
@click.option("--every", type=click.IntRange(min=1), default=1, show_default=True,
              help="Use every N-th saved frame.")
@click.option("--start", type=float, default=None, metavar="SECONDS",
              help="Render only the frames from this simulated time on.")
@click.option("--end", type=float, default=None, metavar="SECONDS",
              help="Render only the frames up to this simulated time.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@click.option("--plate", is_flag=True,
              help="A round white plate on the floor under the body, as `jellysim demo` draws.")
@click.option("--clock", is_flag=True,
              help="Write each frame's simulated time (time 0.517 s) in the upper right "
                   "corner.")
@click.option("--no-antialias", "no_antialias", is_flag=True,
              help="Jagged edges, faster (without a GPU smoothing costs ~25 ms a frame).")
@click.option("--label", "label", multiple=True, metavar="TEXT",
              help="A caption in the upper left: one per run, in order (default for several "
                   "runs side by side: their folders' names).")
@_overwrite
@_camera_options
@click.option("--camera", "camera_mode", type=click.Choice(["auto", "fixed", "follow"]),
              default="auto", show_default=True,
              help="fixed: one view of the whole motion; follow: the camera travels with the "
                   "body; auto: follow a body that travels more than 4 times its size.")
@click.option("--background", default=None, metavar="COLOR|transparent",
              help="Background colour (a name or #rrggbb), or 'transparent' for PNG output "
                   "with an alpha channel (with --no-floor: the jello alone, for slides).")
def render(trajectory, output, show, size, fps, color, opacity, no_floor, frame, every,
           quiet, overwrite=False, azimuth=None, elevation=None, zoom=1.0,
           camera_mode="auto", background=None, start=None, end=None, plate=False,
           clock=False, label=(), no_antialias=False):
    """Render TRAJECTORY (a run folder or its trajectory.npz) to a video or pictures, off
    screen.  Several runs are drawn side by side, at one scale, each at the time of the
    first's frames (soft vs firm)."""
    import numpy as np

    try:
        runs = [_load(tr) for tr in trajectory]
        traj = runs[0]
        t = np.asarray(traj.times, dtype=np.float64)
        lo = -np.inf if start is None else start
        hi = np.inf if end is None else end
        if lo > hi:
            raise JellysimError(f"--start {start:g} s is after --end {end:g} s: swap them")
        window = np.flatnonzero((t >= lo - 1e-9) & (t <= hi + 1e-9))
        if not len(window):
            raise JellysimError(f"--start/--end select no frame: the run's frames span "
                                f"{t[0]:g} .. {t[-1]:g} s")
        frames = window[::every]
        if frame is not None:
            if not -traj.frame_count <= frame < traj.frame_count:
                raise JellysimError(f"--frame {frame} is outside [0, {traj.frame_count - 1}] "
                                    f"(or -1 .. -{traj.frame_count} from the end)")
            frames = np.array([frame % traj.frame_count])
        options = dataclasses.replace(_options(size, color, opacity, show, no_floor,
                                               (azimuth, elevation, zoom)), camera=camera_mode,
                                      plate=plate, clock=clock, antialias=not no_antialias,
                                      zoom_on=-1 if frame is None else int(frames[0]))
        if background is not None:
            if background != "transparent":
                try:
                    _check_color(background)
                except click.BadParameter:
                    raise JellysimError(f"--background {background!r} is not a colour: give "
                                        "a name (white), #rrggbb or 'transparent'") from None
            options = dataclasses.replace(options, background=background)
        if len(runs) > 1 and camera_mode == "follow":
            raise JellysimError("side by side the runs share one fixed camera (one scale): "
                                "remove --camera follow, or render the runs one at a time")
        _warn_inside_out(traj)  # (as export does: a mirrored run's skin is shaded inside out)
        guard_output(output, overwrite)  # (after the checks: a refusal deletes nothing)
        if label and len(label) != len(runs):
            raise JellysimError(f"{len(label)} --label given for {len(runs)} run(s): give one "
                                "per run, in the order of the runs")
        labels = (list(label) if label else [_run_name(tr) for tr in trajectory]
                  if len(runs) > 1 else None)
        # (a file goes to a temporary name, then renamed; a folder's frames are staged and
        # replace the old ones once all are written: render_trajectory)
        path = render_trajectory(traj, output, options, fps=fps, frames=frames,
                                 progress=not quiet, beside=runs[1:], labels=labels,
                                 overwrite=overwrite)
    except JellysimError as exc:
        _fail(str(exc))
    click.echo(f"wrote {path}")


@click.command()
@click.argument("trajectory", type=click.Path())
@click.argument("target", required=False, type=click.Path(), metavar="[OUTPUT]")
@click.option("-o", "--output", default=None, type=click.Path(),
              help="run.usdc / .usda (USD), run.glb (glTF), run.pvd (ParaView series; its "
                   ".vtu frames go into the folder run/), table.csv (per frame: time, centre "
                   "of mass and its velocity, energies; SI units in the header), or a folder "
                   "with --sequence.  May also be given as the second argument.")
@click.option("--sequence", type=click.Choice(["obj", "ply"]), default=None,
              help="Write the skin as one OBJ/PLY file per frame into the folder OUTPUT.")
@click.option("--fps", type=click.FloatRange(min=0.1), default=None,
              help="Time codes per second of the USD stage (default: the run's frame "
                   "rate; any rate plays in real time, e.g. 24 for a 24 fps project).")
@click.option("--max-frames", type=click.IntRange(min=2), default=None,
              help="glb: keep at most this many frames (evenly spaced), one morph target "
                   "each.")
@click.option("--texture", type=click.Path(), multiple=True, metavar="[NAME=]IMAGE",
              help="A .png/.jpg image mapped on the skin by its mesh file's UVs: embedded in "
                   "a .glb, named by a .usd* stage or the OBJ frames' .mtl (relative path); "
                   "the material is then opaque.  For a mesh of several materials, "
                   "NAME=IMAGE gives material NAME its own (repeatable).")
@_overwrite
def export(trajectory, target, output, sequence, fps, max_frames, texture=(),
           overwrite=False):
    """Export TRAJECTORY for other tools: USD, glTF (.glb), ParaView (.pvd), OBJ/PLY, CSV.

    \b
    jellysim export out/run/trajectory.npz -o run.glb
    jellysim export out/run/trajectory.npz --sequence obj frames/
    jellysim export out/run -o table.csv"""
    if output and target and Path(output) != Path(target):
        _fail(f"two outputs given ('{target}' and -o '{output}'); give one")
    if not (output or target):
        _fail("no output given: jellysim export TRAJECTORY -o run.glb (or .usdc, .pvd), or "
              "--sequence obj|ply FOLDER")
    out = Path(output or target)
    suffix = out.suffix.lower()
    if fps is not None and (sequence or suffix not in (".usdc", ".usda", ".usd")):
        _fail("--fps sets the frame rate of a USD stage (.usdc/.usda/.usd); glTF and the other "
              "formats keep the trajectory's own times: remove it")
    if max_frames is not None and (sequence or suffix != ".glb"):
        _fail("--max-frames applies to .glb exports (one morph target per frame): remove it")
    if texture and (sequence == "ply" or not sequence and suffix not in (
            ".usdc", ".usda", ".usd", ".glb")):
        _fail("--texture applies to .glb, .usdc/.usda/.usd and --sequence obj exports (the "
              "others carry no material): remove it")
    try:
        from .io.texture import parse_textures

        texture = parse_textures(texture)
        traj = _load(trajectory)
        if suffix not in (".pvd", ".csv") or sequence:  # (ParaView shows both sides)
            _warn_inside_out(traj)
        if sequence:
            if out.suffix and not out.is_dir():
                raise JellysimError(f"{out}: --sequence writes one file per frame into a "
                                    "folder; give a folder name (no suffix)")
            from .io.atomic import guard_folder
            from .io.usd import surface_of

            surface_of(traj)  # (no surface to write: refused before old frames go)
            guard_folder(out, [f"skin_[0-9]*.{sequence}"], overwrite)
            paths = export_mesh_sequence(traj, out, fmt=sequence, overwrite=True,  # (staged)
                                         texture=texture)
            click.echo(f"wrote {len(paths)} {sequence.upper()} files in {out}")
            return
        suffix = out.suffix.lower()
        if suffix in (".usdc", ".usda", ".usd", ".glb", ".pvd", ".csv"):
            guard_output(out, overwrite)
        if suffix in (".usdc", ".usda", ".usd"):
            written = [export_usd(traj, out, fps=fps, overwrite=True,  # (guarded above)
                                  texture=texture)]
        elif suffix == ".glb":
            written = [export_glb(traj, out, max_frames=max_frames, overwrite=True,
                                  texture=texture)]
        elif suffix == ".csv":
            from .plot import write_table

            written = [write_table(traj, out, overwrite=True)]  # (guarded above)
        elif suffix == ".pvd":  # the .pvd and its frame folder replace the old together
            from .io.atomic import staged_output

            with staged_output(out.parent, [f"{out.stem}_[0-9]*.vtu",
                                            f"{out.stem}_skin_[0-9]*.vtu"]) as stage:
                written = [out.parent / p.name for p in export_pvd_file(traj, stage / out.name)]
        else:
            raise JellysimError(f"{out}: unknown export type '{suffix}'; use .usdc, .usda, "
                                ".glb, .pvd, .csv, or --sequence obj|ply with a folder")
    except JellysimError as exc:
        _fail(str(exc))
    for p in written:
        click.echo(f"wrote {p}")


@click.command()
@click.argument("trajectory", type=click.Path())
@_show
@_size_opt
@_color
@_opacity
@_floor
@click.option("--fps", type=click.FloatRange(min=0.1), default=None,
              help="Playback speed in frames per second (default: real time).")
@click.option("--screenshot", type=click.Path(dir_okay=False), default=None,
              help="Draw the window, save it to this PNG and close (no interaction).")
@_camera_options
def view(trajectory, show, size, color, opacity, no_floor, fps, screenshot, azimuth=None,
         elevation=None, zoom=1.0):
    """Interactive window over TRAJECTORY: play/pause (check box or space), scrub (slider),
    orbit (mouse).  Given a scene file (.toml) instead, it simulates live and the right mouse
    button pulls the jello (a spring to the cursor)."""

    if str(trajectory).endswith(".toml"):
        from .scene import Scene

        if azimuth is not None or elevation is not None or zoom != 1.0:
            _fail("--azimuth / --elevation / --zoom frame a saved trajectory; the live view of "
                  "a scene is orbited with the mouse: remove them")

        try:
            view_live(Scene.load(trajectory), size=_size(size), screenshot=screenshot,
                      frames=30 if screenshot else 0)
        except JellysimError as exc:
            _fail(str(exc))
        if screenshot:
            click.echo(f"wrote {screenshot}")
        return
    try:
        traj = _load(trajectory)
        view_trajectory(traj, _options(size, color, opacity, show, no_floor,
                                       (azimuth, elevation, zoom)), fps=fps,
                        screenshot=screenshot)
    except JellysimError as exc:
        _fail(str(exc))
    if screenshot:
        click.echo(f"wrote {screenshot}")


@click.command()
@click.argument("trajectory", type=click.Path())
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False),
              help="energy.png or .svg / .pdf")
@_overwrite
def plot(trajectory, output, overwrite=False):
    """Plot energies, centre-of-mass height and largest spring strain of TRAJECTORY."""

    from .io.atomic import guard_file

    try:
        guard_file(output, overwrite)
        path = plot_trajectory(_load(trajectory), output, title=_run_name(trajectory),
                               overwrite=True)  # (guarded above)
    except JellysimError as exc:
        _fail(str(exc))
    click.echo(f"wrote {path}")


def register(group) -> None:
    """Add the visual commands to the ``jellysim`` click group."""
    for cmd in (demo, render, export, view, plot):
        group.add_command(cmd)
