"""``jellysim inspect OUT``: a run's figures from its trajectory, for parameter studies.

Every figure is computed from the stored frames (SI units): the centre of mass [m], the
kinetic energy ``sum m v^2 / 2`` [J], the gravity energy ``-M g . c`` [J] relative to the first
frame, the springs' elastic energy ``sum k (|d| - L0)^2 / 2`` [J] (bodies on springs), a
physical run's tets' elastic energy [J] (as :func:`jellysim.plot.diagnostics` computes it),
the smallest tet volume ratio ``J`` (a frame's signed volume over the rest volume; below 0:
inside out).
"""
from __future__ import annotations

import numpy as np

__all__ = ["trajectory_rows"]


def _kinetic(traj, f: int) -> float:
    v = traj.velocities[f]
    return 0.5 * float(traj.masses @ np.einsum("ij,ij->i", v, v))


def _springs(traj, f: int) -> float | None:
    if not len(traj.springs) or not np.any(traj.stiffness != 0):
        return None
    x = traj.positions[f]
    d = x[traj.springs[:, 1]] - x[traj.springs[:, 0]]
    stretch = np.linalg.norm(d, axis=1) - traj.rest_length
    return 0.5 * float(traj.stiffness @ (stretch * stretch))


def _volume_ratios(traj, f: int) -> np.ndarray:
    from .geometry.tetra import tet_signed_volumes

    rest = tet_signed_volumes(traj.rest_positions, traj.tets)
    return tet_signed_volumes(traj.positions[f], traj.tets) / np.where(rest != 0, rest, 1.0)


def trajectory_rows(traj) -> list[tuple[str, str]]:
    """(label, text) rows describing :class:`~jellysim.io.trajectory.Trajectory` ``traj``."""
    frames = traj.frame_count
    if frames == 0:
        return [("frames", "0"), ("status", traj.status)]
    mass = float(traj.masses.sum())
    w = traj.masses / mass if mass > 0 else np.full(traj.point_count, 1.0 / traj.point_count)
    com = [w @ traj.positions[f] for f in (0, frames - 1)]
    kinetic = [_kinetic(traj, f) for f in range(frames)]
    gravity = -mass * float(np.asarray(traj.gravity) @ (com[1] - com[0]))
    rows = [
        ("frames", f"{frames} (t = {traj.times[0]:.6g} to {traj.times[-1]:.6g} s, steps "
                   f"{int(traj.steps[0])} to {int(traj.steps[-1])})"),
        ("status", traj.status),
        ("points", f"{traj.point_count} ({mass:.6g} kg), {len(traj.springs)} springs, "
                   f"{len(traj.tets)} tets"),
        ("centre [m]", f"({', '.join(f'{c:.6g}' for c in com[0])}) -> "
                       f"({', '.join(f'{c:.6g}' for c in com[1])})"),
        ("lowest y [m]", f"{float(traj.positions[0][:, 1].min()):.6g} -> "
                         f"{float(traj.positions[-1][:, 1].min()):.6g}"),
        ("kinetic [J]", f"{kinetic[-1]:.6g} at the end (largest {max(kinetic):.6g}, at t = "
                        f"{traj.times[int(np.argmax(kinetic))]:.6g} s)"),
        ("gravity [J]", f"{gravity:.6g} (the end's over the first frame's, -M g . dc)"),
    ]
    elastic = _springs(traj, frames - 1)
    if elastic is not None:
        rows.append(("springs [J]", f"{elastic:.6g} elastic at the end (first frame "
                                    f"{_springs(traj, 0):.6g})"))
    if (traj.params or {}).get("fem") and len(traj.tets):  # (a physical run: its material)
        from .plot import _tet_energy

        first, end = _tet_energy(traj, np.asarray(traj.positions)[[0, frames - 1]])
        rows.append(("tets [J]", f"{end:.6g} elastic at the end (first frame {first:.6g}; "
                                 "Stable Neo-Hookean, from the run's material)"))
    if len(traj.tets):
        smallest = [float(_volume_ratios(traj, f).min()) for f in range(frames)]
        k = int(np.argmin(smallest))
        rows.append(("tet volume", f"smallest ratio {smallest[-1]:.4g} at the end, "
                                   f"{smallest[k]:.4g} at t = {traj.times[k]:.6g} s (the "
                                   "frames' smallest; below 0: inside out)"))
    if traj.skin is not None:  # what the exports carry
        s = traj.skin
        rows.append(("skin", f"{s.vertex_count} vertices, {len(s.faces)} faces" + (
            ", with texture coordinates (export --texture IMAGE maps an image)"
            if s.uv is not None else ", no texture coordinates")))
        if s.materials is not None:
            rows.append(("materials", ", ".join(
                f"{n!r} ({int((s.materials.index == k).sum())} faces)"
                for k, n in enumerate(s.materials.names)) + ": --texture NAME=IMAGE each"))
    return rows
