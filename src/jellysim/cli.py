"""Command line: ``jellysim run scene.toml --out DIR`` and friends."""
from __future__ import annotations

import sys

import click

from .errors import JellysimError


def _fail(message: str) -> None:
    click.secho(f"error: {message}", fg="red", err=True)
    sys.exit(2)


@click.group()
@click.version_option(package_name="jellysim")
def cli() -> None:
    """jellysim: soft, wobbly bodies as 3D mass-spring networks."""


@cli.command()
@click.argument("scene_file", type=click.Path(dir_okay=False))
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default=None,
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
def run(scene_file, out_dir, steps, no_vtu, quiet, video=None, usd=None, glb=None) -> None:
    """Simulate SCENE_FILE (TOML) and write trajectory.npz and body.pvd."""
    from pathlib import Path

    from .runner import run_scene
    from .scene import Scene

    try:
        scene = Scene.load(scene_file)
        out = Path(out_dir) if out_dir else Path("out") / Path(scene_file).stem
        result = run_scene(scene, out, progress=not quiet, vtu=False if no_vtu else None,
                           steps=steps)
    except JellysimError as exc:
        _fail(str(exc))
    for w in result.warnings:
        click.secho(f"warning: {w}", fg="yellow", err=True)
    rate = result.steps / result.seconds if result.seconds > 0 else float("inf")
    click.echo(f"{result.steps} steps, {result.frames} frames in {result.seconds:.3g} s "
               f"({rate:,.0f} steps/s)")
    click.echo(f"wrote {result.trajectory}")
    if result.pvd:
        click.echo(f"wrote {result.pvd} (+ {result.frames} .vtu frames)")
    from .cli_visual import write_run_outputs

    try:
        for p in write_run_outputs(result.trajectory, video=video, usd=usd, glb=glb,
                                   progress=not quiet):
            click.echo(f"wrote {p}")
    except JellysimError as exc:
        _fail(str(exc))


@cli.command("scene-help")
def scene_help() -> None:
    """Print every scene key, its default and allowed range (Markdown)."""
    from .scene import schema_markdown

    click.echo(schema_markdown())


from .cli_visual import register; register(cli)  # noqa: E402,E702 (demo render export view plot)


def main() -> None:
    cli()


if __name__ == "__main__":
    main()
