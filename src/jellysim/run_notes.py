"""What a run says about itself while it runs: how long it will take, how to continue it."""
from __future__ import annotations

import shlex

__all__ = ["SLOW_RUN_SECONDS"]

SLOW_RUN_SECONDS = 120.0
"""A run whose pace after its first frames leaves more than this many seconds says so."""

PACE_STEPS, PACE_SECONDS = 5, 10.0
"""The pace is judged over at least this many steps after the first frame, or seconds."""


def _say_if_slow(notify, sim, seconds: float, steps: int, left: int) -> bool:
    """Tell ``notify`` how long the rest of a run takes at the pace of its second frame
    (``steps`` steps in ``seconds``; the first frame includes compiling) when that is more
    than :data:`SLOW_RUN_SECONDS`, and why (substeps per step), with what is faster.
    Returns True (said, or nothing to say), False while the window is too short to judge:
    fewer than :data:`PACE_STEPS` steps and under :data:`PACE_SECONDS` (a frame's first
    contact, a kernel loaded at first use or the thread count's probe makes one frame cost
    many: a 1,478-point cow's second step took 2.2 s, its next 58 steps 0.12 s each)."""
    if notify is None or steps <= 0 or seconds <= 0:
        return True
    if steps < PACE_STEPS and seconds < PACE_SECONDS and left > 0:
        return False
    eta = seconds / steps * left
    if eta > SLOW_RUN_SECONDS:
        sub = getattr(sim, "substeps", 1)
        pace = f"{sim.model.point_count:,} points, " + (
            f"{sub} substeps per step of {sim.dt:g} s: " if sub > 1 else "") + (
            f"{steps / seconds:.3g} steps/s, {sim.dt * steps / seconds:.2g}x real time")
        when = f"{eta / 60:.0f} min" if eta >= 90 else f"{eta:.0f} s"
        notify(f"at this pace the run takes about {when} more ({pace}); Ctrl-C stops it "
               "with its frames and a "
               "checkpoint (--resume continues); fewer points (larger tets need fewer "
               "substeps), connect = 'marching' or fewer steps are faster")
    return True


def _resume_command(scene, out_dir) -> str:
    """How to continue a run of ``scene`` in ``out_dir``: the command line for a scene file,
    the Python call for a scene made in Python without a name (no file to name)."""
    if getattr(scene, "from_run", None) is not None:  # (resumed from the run's own record)
        return (f"jellysim run --resume {shlex.quote(str(out_dir))}" + "".join(
            f" --set {shlex.quote(item)}" for item in getattr(scene, "overrides", ())))
    if str(scene.name) != "<scene>":
        return (f"jellysim run {shlex.quote(str(scene.name))} --resume "
                f"{shlex.quote(str(out_dir))}" + "".join(
                    f" --set {shlex.quote(item)}" for item in getattr(scene, "overrides", ())))
    return f"run_scene(scene, {str(out_dir)!r}, resume=True) with the same scene"
