"""Diagnostics of a saved trajectory against time, and ``jellysim plot`` (matplotlib).

Quantities per frame (SI units):

* kinetic energy ``sum 1/2 m |v|^2`` [J]
* elastic energy: the springs' ``sum 1/2 k (|x_j - x_i| - L0)^2`` [J], plus, for a physical
  (FEM) run, the tets' Stable Neo-Hookean energy (:func:`jellysim.physics.fem.elastic_energy`,
  rebuilt from the trajectory's tets and the E and nu it records)
* gravitational energy ``-sum m g . x`` [J], zero on the ground plane (``y = height``)
* centre-of-mass height [m] above the ground plane (``y - height``: above the plate also
  where ``g`` is tilted to make a slope), its position ``sum m x / M`` [m]
  and velocity ``sum m v / M`` [m/s], and how far it has moved along the ground (in the x-z
  plane) since the first frame [m] (a block sliding on the plate, or down a slope made by
  tilting ``g``)
* largest spring strain ``max |(|x_j - x_i| - L0) / L0|`` [-]
* smallest tet volume ratio ``V / V0`` (J) [-] of a physical (FEM) run: below 1 squeezed,
  below 0 inside out (its springs, when it has any, only draw it: their strain is not a force)

:func:`write_table` writes them as a CSV file (``jellysim export RUN -o table.csv``) for a
spreadsheet or a class's own analysis.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import JellysimError
from .io.atomic import atomic_path, guard_file

__all__ = ["diagnostics", "plot_trajectory", "write_table"]

TABLE_COLUMNS = (("time", "time_s"), ("com_x", "com_x_m"), ("com_y", "com_y_m"),
                 ("com_z", "com_z_m"), ("com_vx", "com_vx_m_per_s"),
                 ("com_vy", "com_vy_m_per_s"), ("com_vz", "com_vz_m_per_s"),
                 ("com_height", "com_height_m"), ("top_height", "top_height_m"),
                 ("travel", "travel_xz_m"),
                 ("kinetic", "kinetic_J"), ("elastic", "elastic_J"), ("gravity", "gravity_J"),
                 ("total", "total_J"), ("max_strain", "max_spring_strain"),
                 ("min_volume_ratio", "min_tet_volume_ratio"))
"""The CSV's columns: (:func:`diagnostics` key, header with its unit)."""


def diagnostics(traj) -> dict[str, np.ndarray]:
    """Per-frame diagnostics, each shape (F,): ``time`` [s], ``kinetic`` [J], ``spring`` [J]
    (the springs' energy), ``tets`` [J] (the FEM tets' energy; zeros without), ``gravity``
    [J], ``total`` [J], ``com_height`` [m] (above the ground plane), ``top_height`` [m] (the
    highest point's, above the ground plane: a sweep's resting height), ``max_strain`` [-] (of
    the springs, a fraction); the centre
    of mass ``com_x``, ``com_y``, ``com_z`` [m] and its velocity ``com_vx`` ... [m/s];
    ``travel`` [m] its distance in the x-z plane (along the ground) from the first frame;
    ``elastic`` [J] = spring + tets; ``min_volume_ratio`` [-] the smallest J = V / V0 of the
    run's tets (a springs body's own tets too, as ``inspect`` gives it: a folded spring body
    shows J < 0; NaN for a body without tets)."""
    x = np.asarray(traj.positions, dtype=np.float64)
    v = np.asarray(traj.velocities, dtype=np.float64)
    m = np.asarray(traj.masses, dtype=np.float64)
    g = np.asarray(traj.gravity, dtype=np.float64)
    gnorm = float(np.linalg.norm(g))
    up = -g / gnorm if gnorm > 0 else np.array([0.0, 1.0, 0.0])
    ground = traj.params.get("ground", {}).get("height", 0.0) if traj.params else 0.0
    kinetic = 0.5 * np.einsum("n,fnd,fnd->f", m, v, v)
    height = x @ up - float(ground)                       # (F, n)
    grav = gnorm * height @ m
    s = np.asarray(traj.springs, dtype=np.int64)
    if len(s):  # a few frames at a time: all at once took 1.1 GB for a 10,948-point body's
        spring, strain = np.zeros(len(x)), np.zeros(len(x))  # 181 frames (scale trial)
        step = max(1, int(2**20 // max(1, len(s))))  # (~25 MB a spring-vector array)
        for a in range(0, len(x), step):
            xs = x[a:a + step]
            stretch = np.linalg.norm(xs[:, s[:, 1]] - xs[:, s[:, 0]], axis=2) - traj.rest_length
            spring[a:a + step] = 0.5 * (stretch**2) @ traj.stiffness
            strain[a:a + step] = np.abs(stretch / traj.rest_length).max(axis=1)
    else:
        spring = strain = np.zeros(len(x))
    tets = _tet_energy(traj, x)
    centre, velocity = (x.transpose(0, 2, 1) @ m) / m.sum(), (v.transpose(0, 2, 1) @ m) / m.sum()
    travel = np.hypot(centre[:, 0] - centre[0, 0], centre[:, 2] - centre[0, 2])
    out = {"time": np.asarray(traj.times, dtype=np.float64), "kinetic": kinetic,
           "spring": spring, "tets": tets, "elastic": spring + tets, "gravity": grav,
           "total": kinetic + spring + tets + grav, "com_height": centre[:, 1] - float(ground),
           "top_height": height.max(axis=1) if height.shape[1] else np.zeros(len(x)),
           "max_strain": strain, "travel": travel}
    for k, axis in enumerate("xyz"):
        out[f"com_{axis}"], out[f"com_v{axis}"] = centre[:, k], velocity[:, k]
    out["min_volume_ratio"] = _min_volume_ratio(traj, x)
    return out


def _min_volume_ratio(traj, x) -> np.ndarray:
    """The smallest tet volume ratio J per frame [-] of a run with tets (NaN without)."""
    if len(traj.tets) == 0:
        return np.full(len(x), np.nan)
    from .geometry.tetra import tet_signed_volumes

    tets = np.asarray(traj.tets, dtype=np.int64)
    rest = tet_signed_volumes(np.asarray(traj.rest_positions, dtype=np.float64), tets)
    return np.array([float(np.min(tet_signed_volumes(xf, tets) / rest)) for xf in x])


def write_table(traj, path, *, overwrite: bool = False) -> Path:
    """Write :func:`diagnostics` as a CSV file: one row per frame, the columns of
    :data:`TABLE_COLUMNS` (SI units, named in the header line).  An existing file is refused
    unless ``overwrite`` (:class:`~jellysim.errors.OutputError`)."""
    path = Path(path)
    if path.suffix.lower() != ".csv":
        raise JellysimError(f"{path}: a table file name must end in .csv")
    guard_file(path, overwrite, flag="overwrite=True")
    d = diagnostics(traj)
    table = np.column_stack([d[key] for key, _ in TABLE_COLUMNS])
    with atomic_path(path) as tmp:
        np.savetxt(tmp, table, delimiter=",", fmt="%.10g", comments="",
                   header=",".join(name for _, name in TABLE_COLUMNS))
    return path


def _tet_energy(traj, x) -> np.ndarray:
    """The FEM tets' stored energy per frame [J] (zeros for a springs run)."""
    fem = (traj.params or {}).get("fem")
    if not fem or len(traj.tets) == 0:
        return np.zeros(len(x))
    from .geometry.tetra import orient_tets
    from .physics.fem import elastic_energy, fem_arrays

    rest = np.asarray(traj.rest_positions, dtype=np.float64)
    arrays = fem_arrays(rest, orient_tets(rest, traj.tets),
                        youngs_modulus=fem["youngs_modulus"], poisson_ratio=fem["poisson_ratio"])
    return np.array([elastic_energy(arrays, xf) for xf in x])


def sideways(d) -> dict[str, np.ndarray]:
    """The centre of mass's sideways offsets [m], shape (F,) each, from its first frame, signed
    (what :func:`plot_trajectory` draws), from a :func:`diagnostics` table ``d``."""
    return {f"{k} - {k}(0)": d[f"com_{k}"] - d[f"com_{k}"][0] for k in ("x", "z")}


def plot_trajectory(traj, path, *, title: str | None = None,
                    overwrite: bool = False) -> Path:
    """Draw against time to ``path`` (``.png``, ``.svg`` or ``.pdf``): the kinetic and
    elastic energies (the wobble's exchange, on their own scale), the gravitational and total
    energies' change since the start, the centre-of-mass height, its sideways offsets from
    the start (signed: a sway swings either side of its line; session 28's teacher trial
    found only the distance moved, never negative, which drew a sway as a row of bumps) and
    the largest strain or squeeze.  An existing file is refused unless ``overwrite``
    (:class:`~jellysim.errors.OutputError`)."""
    path = Path(path)
    if path.suffix.lower() not in (".png", ".svg", ".pdf"):
        raise JellysimError(f"{path}: plot file must end in .png, .svg or .pdf")
    if traj.frame_count == 0:
        raise JellysimError("the trajectory has no frames to plot")
    guard_file(path, overwrite, flag="overwrite=True")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt


    d = diagnostics(traj)
    t = d["time"]
    fig, axes = plt.subplots(5, 1, figsize=(8, 13), sharex=True, constrained_layout=True)
    ax = axes[0]  # the wobble's exchange, on its own scale (gravity's would flatten it)
    ax.plot(t, d["kinetic"], label="kinetic")
    if np.any(d["tets"]):
        ax.plot(t, d["tets"] + d["spring"], label="elastic (tets + springs)")
    else:
        ax.plot(t, d["spring"], label="spring")
    ax.set_ylabel("energy [J]")
    ax.legend(loc="best")
    ax = axes[1]
    ax.plot(t, d["gravity"] - d["gravity"][0], label="gravitational")
    ax.plot(t, d["total"] - d["total"][0], "k--", lw=1, label="total")
    ax.set_ylabel("change since the start [J]")
    ax.legend(loc="best")
    axes[2].plot(t, d["com_height"], color="C3")
    axes[2].set_ylabel("centre of mass height [m]")
    ax = axes[3]  # on their own scale: a millimetre sway beside a 5 cm height would be flat
    offsets = sideways(d)
    for (label, series), colour in zip(offsets.items(), ("C2", "C1")):
        ax.plot(t, series, color=colour, label=label)
    ax.axhline(0.0, color="k", lw=0.8, ls=":")
    size = float(np.ptp(np.asarray(traj.rest_positions), axis=0).max())
    floor = 1e-4 * size  # (sweep trial, session 30: no sway was drawn as +-2e-16 m of noise)
    if floor > 0 and max(float(np.abs(v).max()) for v in offsets.values()) < floor:
        ax.set_ylim(-floor, floor)
    ax.set_ylabel("centre of mass, sideways [m]")
    ax.legend(loc="best")
    ax = axes[4]
    if np.all(np.isnan(d["min_volume_ratio"])):
        ax.plot(t, 100 * d["max_strain"], color="C4")
        ax.set_ylabel("largest spring strain [%]")
    else:  # (a physical run: its tets carry it, J is what says it is squeezed or inverted)
        ax.plot(t, d["min_volume_ratio"], color="C4")
        ax.axhline(0.0, color="k", lw=0.8, ls=":")
        ax.set_ylabel("smallest tet volume ratio V / V0")
    ax.set_xlabel("time [s]")
    for a in axes:
        a.grid(alpha=0.3)
    status = "" if traj.status == "complete" else f" ({traj.status[:60]})"
    fig.suptitle((title or "jellysim trajectory") + status)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format=path.suffix.lower().lstrip("."))
    plt.close(fig)
    return path
