"""Measure a lesson's run and set it beside its textbook formula (docs/lessons.md).

    python examples/lessons/measure.py slide   out/slide      # stopping distance
    python examples/lessons/measure.py incline out/incline    # acceleration down the slope
                                                              # (below the friction angle,
                                                              # pushed: the stopping distance)
    python examples/lessons/measure.py wobble  out/wobble     # sway frequency
    python examples/lessons/measure.py decay   out/wobble_damped   # damping ratio of the sway

It reads runs made by ``jellysim run`` (or ``jellysim.runner.run_scene``): mu, E and the
push come from the run's scene.  Everything is read from the run's saved trajectory through
``jellysim.plot.diagnostics``
(the same numbers as ``jellysim export RUN -o table.csv``): the centre of mass, its velocity
and how far it moved along the ground, per frame.  The formulas take their inputs (v0, mu, g,
E, nu, rho, the cube's side) from the run itself.  Each function returns
``(measured, formula, text)``.
"""
from __future__ import annotations

import sys

import numpy as np


def _table(traj):
    from jellysim.plot import diagnostics

    return diagnostics(traj)


def slide(traj):
    """Stopping distance [m] against v0^2 / (2 mu g)."""
    d = _table(traj)
    v0 = float(np.hypot(d["com_vx"][0], d["com_vz"][0]))
    mu = traj.params["ground"]["friction"]
    g = float(np.linalg.norm(traj.gravity))
    formula = v0**2 / (2 * mu * g)
    measured = float(d["travel"][-1])
    still = abs(d["com_vx"][-1]) < 1e-3 * v0
    return measured, formula, (f"slid {measured:.4f} m{'' if still else ' (still moving)'}; "
                               f"v0^2 / (2 mu g) = {v0:g}^2 / (2 x {mu:g} x {g:.3g}) = "
                               f"{formula:.4f} m ({measured / formula - 1:+.1%})")


def incline(traj, after: float = 0.2):
    """Acceleration [m/s^2] down the slope made by tilting g, against g (sin t - mu cos t):
    a parabola fitted to the distance moved after ``after`` seconds (the first moments are
    the block dropping into its sag).  Below the friction angle (tan t < mu) a block pushed
    down the slope at v0 brakes at g (mu cos t - sin t): then its stopping distance [m]
    against v0^2 / (2 g (mu cos t - sin t))."""
    d = _table(traj)
    g = np.asarray(traj.gravity, dtype=np.float64)
    theta = float(np.arctan2(np.hypot(g[0], g[2]), -g[1]))
    mu = traj.params["ground"]["friction"]
    size = float(np.linalg.norm(g))
    slope = f"theta = {np.degrees(theta):.1f} deg (tan = {np.tan(theta):.3f}, mu = {mu:g})"
    braking = size * (mu * np.cos(theta) - np.sin(theta))
    v0 = float(np.hypot(d["com_vx"][0], d["com_vz"][0]))
    if braking > 0 and v0 > 0:
        formula, measured = v0**2 / (2 * braking), float(d["travel"][-1])
        still = abs(d["com_vx"][-1]) < 1e-3 * v0
        return measured, formula, (
            f"{slope}: below the friction angle, pushed at {v0:g} m/s it brakes at "
            f"g (mu cos theta - sin theta) = {braking:.3f} m/s^2; it slid "
            f"{1000 * measured:.2f} mm{'' if still else ' (still moving)'}; v0^2 / (2 x "
            f"{braking:.3f}) = {1000 * formula:.2f} mm ({measured / formula - 1:+.1%})")
    formula = max(0.0, -braking)
    t = d["time"] - d["time"][0]
    late = t > after
    measured = float(2 * np.polyfit(t[late], d["travel"][late], 2)[0])
    return measured, formula, (f"{slope}: accelerates at {measured:.3f} m/s^2 (fitted after "
                               f"{after:g} s); g (sin theta - mu cos theta) = {formula:.3f} "
                               "m/s^2")


def _sway(traj, after: float):
    """Times [s] of the centre of mass's sideways crossings of its mean, after ``after``,
    and its offsets [m]."""
    d = _table(traj)
    t, x = d["time"] - d["time"][0], d["com_x"]
    late = t > after
    t, u = t[late], x[late] - x[late].mean()
    k = np.flatnonzero(np.sign(u[:-1]) * np.sign(u[1:]) < 0)
    return t[k] - u[k] * (t[k + 1] - t[k]) / (u[k + 1] - u[k]), t, u


def _push_end(traj) -> float:
    ends = [h.get("until") for h in traj.params.get("handle", []) if h.get("kind") == "force"]
    return max([e for e in ends if e is not None] or [0.0])


def wobble(traj):
    """Sway frequency [Hz] after the push, against Dunkerley's shear + bending estimate."""
    crossings, _, _ = _sway(traj, _push_end(traj) + 0.05)
    measured = float(0.5 / np.mean(np.diff(crossings)))
    mat = traj.params["material"]
    e, nu, rho = mat["youngs_modulus"], mat["poisson_ratio"], mat["density"]
    side = float(np.ptp(np.asarray(traj.rest_positions)[:, 1]))
    shear = np.sqrt(e / (2 * (1 + nu)) / rho) / (4 * side)
    bending = 1.875**2 / (2 * np.pi * side**2) * np.sqrt(e * side**2 / 12 / rho)
    formula = float(1 / np.sqrt(1 / shear**2 + 1 / bending**2))
    return measured, formula, (f"sways at {measured:.3f} Hz ({len(crossings) // 2} periods "
                               f"counted); shear {shear:.2f} Hz and bending {bending:.2f} Hz "
                               f"combine (Dunkerley) to {formula:.3f} Hz "
                               f"({measured / formula - 1:+.1%})")


def decay(traj):
    """Damping ratio of the sway from its logarithmic decrement, against the material's
    ``damping_ratio``."""
    crossings, t, u = _sway(traj, _push_end(traj) + 0.05)
    peaks = [float(np.abs(u[(t > a) & (t < b)]).max())
             for a, b in zip(crossings[:-1], crossings[1:])]
    delta = -np.polyfit(np.arange(len(peaks)), np.log(peaks), 1)[0] * 2  # per period
    measured = float(delta / np.sqrt(4 * np.pi**2 + delta**2))
    formula = float(traj.params["material"]["damping_ratio"])
    return measured, formula, (f"the sway's peaks fall by {np.exp(-delta):.3f} per period: "
                               f"damping ratio {measured:.4f}; the material's "
                               f"damping_ratio = {formula:g}")


LESSONS = {"slide": slide, "incline": incline, "wobble": wobble, "decay": decay}

if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] not in LESSONS:
        sys.exit(f"usage: python {sys.argv[0]} {{{','.join(LESSONS)}}} RUN_FOLDER")
    from jellysim import JellysimError, load_trajectory

    try:
        print(LESSONS[sys.argv[1]](load_trajectory(sys.argv[2]))[2])
    except JellysimError as exc:
        sys.exit(f"error: {exc} (run the lesson's scene first: its header gives the command)")
