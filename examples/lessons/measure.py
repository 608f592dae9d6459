"""Measure a lesson's run and set it beside its textbook formula (docs/lessons.md).

    python examples/lessons/measure.py slide   out/slide      # stopping distance
    python examples/lessons/measure.py incline out/incline    # acceleration down the slope
                                                              # (below the friction angle,
                                                              # pushed: the stopping distance)
    python examples/lessons/measure.py wobble  out/wobble     # sway frequency
    python examples/lessons/measure.py decay   out/wobble_damped   # damping ratio of the sway
    python examples/lessons/measure.py resonance out/resonance     # the swing of a shaken cube

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
    if not v0 > 0 or not mu > 0:
        raise ValueError(f"the run starts at {v0:g} m/s along the ground with friction "
                         f"{mu:g}: no slide to measure (it needs the slide lesson's run, "
                         "examples/lessons/slide.toml: a block launched along a plate with "
                         "friction)")
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
    if not g[1] < 0 or any("shake" in h or h.get("kind") == "pin"
                           for h in traj.params.get("handle", [])):
        raise ValueError("the run has no slope to slide down (gravity does not point down "
                         "onto the plate, or the body is pinned): it needs the incline "
                         "lesson's run, examples/lessons/incline.toml (a re-trial read a "
                         "weightless shaken cube as a 180 deg slope)")
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


def _need_sway(traj, crossings, lesson: str) -> None:
    """Refuse a run with no sway to measure (another lesson's run, or one too short), or one
    whose base is shaken (a driven sway is not a free one: the resonance trial's decay read
    -0.0028)."""
    if any("shake" in h for h in traj.params.get("handle", [])):
        raise ValueError(f"the run's base is shaken (a [[handle]] shake): its sway is driven, "
                         f"not free, so '{lesson}' cannot read it; measure it with "
                         "'resonance' (python examples/lessons/measure.py resonance RUN)")
    if len(crossings) < 4:
        n = len(crossings)
        raise ValueError(f"the run's centre of mass crosses its mean {n} time"
                         f"{'' if n == 1 else 's'} after the push: no sway to measure for '{lesson}' (it needs the "
                         "wobble lesson's run, examples/lessons/wobble.toml, at least a "
                         "couple of periods long)")


def _push_end(traj) -> float:
    ends = [h.get("until") for h in traj.params.get("handle", []) if h.get("kind") == "force"]
    return max([e for e in ends if e is not None] or [0.0])


def wobble(traj):
    """Sway frequency [Hz] after the push, against Dunkerley's shear + bending estimate."""
    crossings, t, u = _sway(traj, _push_end(traj) + 0.05)
    _need_sway(traj, crossings, "wobble")
    measured = damped_fit(t, u, crossings)[3] / (2 * np.pi)  # (damped: the crossings of the
    #                                         mean run fast, 4.48 Hz for 4.21 at zeta 0.2)
    mat = traj.params["material"]
    e, nu, rho = mat["youngs_modulus"], mat["poisson_ratio"], mat["density"]
    side = float(np.ptp(np.asarray(traj.rest_positions)[:, 1]))
    shear = np.sqrt(e / (2 * (1 + nu)) / rho) / (4 * side)
    bending = 1.875**2 / (2 * np.pi * side**2) * np.sqrt(e * side**2 / 12 / rho)
    formula = float(1 / np.sqrt(1 / shear**2 + 1 / bending**2))
    return measured, formula, (f"sways at {measured:.3f} Hz (a damped sine fitted to "
                               f"{len(crossings) // 2} periods); shear {shear:.2f} Hz and bending {bending:.2f} Hz "
                               f"combine (Dunkerley) to {formula:.3f} Hz "
                               f"({measured / formula - 1:+.1%})")


def damped_fit(t, u, crossings):
    """``(c, a, s, w, p)`` of the damped sine ``c + a exp(-s t) cos(w t + p)`` fitted by least
    squares (``scipy.optimize.curve_fit``) to offsets ``u`` [m] at times ``t`` [s] (``t``
    counted from ``t[0]``), started from the ``crossings`` [s] of the mean; and the fit's rms
    misfit over the largest offset.  s [1/s] the decay rate, w [rad/s] the damped angular
    frequency: damping ratio s / sqrt(w^2 + s^2).  (Peaks measured about the mean, as before
    session 28, read 0.30 for 0.2 set: a decaying sway's mean is not its centre, and a heavily
    damped one has few peaks; the crossings of the mean then run fast too: teacher trial.)"""
    from scipy.optimize import curve_fit

    t = np.asarray(t, dtype=np.float64) - t[0]
    u = np.asarray(u, dtype=np.float64)
    w0 = np.pi / float(np.mean(np.diff(crossings)))
    swing = float(np.abs(u).max())

    def sway(t, c, a, s, w, p):
        return c + a * np.exp(-s * t) * np.cos(w * t + p)

    best = None
    for p0 in np.linspace(0.0, 2 * np.pi, 4, endpoint=False):  # (the phase: several starts)
        try:
            got, _ = curve_fit(sway, t, u, p0=(0.0, swing, 0.1 * w0 / np.pi, w0, p0),
                               maxfev=20000)
        except RuntimeError:
            continue
        misfit = float(np.sqrt(np.mean((sway(t, *got) - u) ** 2)))
        if best is None or misfit < best[1]:
            best = got, misfit
    if best is None:
        raise ValueError("no damped sine fits the sway")
    (c, a, s, w, p), misfit = best
    if misfit > 0.1 * swing or s < -0.01 * abs(w):  # (a drop's bounce fitted at 0.7 Hz, 28 %
        raise ValueError(                           # off, "damping ratio -0.017": re-trial)
            f"the sideways motion is no damped sway: a damped sine fits it {misfit / swing:.0%} "
            "off (a sway is fitted to within a few %); it needs the wobble lesson's run, "
            "examples/lessons/wobble.toml")
    return float(c), float(a), float(s), abs(float(w)), float(p), misfit / swing


def decay(traj):
    """Damping ratio of the sway (:func:`damped_fit` to the centre of mass's sideways offset
    after the push) against the material's ``damping_ratio``."""
    crossings, t, u = _sway(traj, _push_end(traj) + 0.05)
    _need_sway(traj, crossings, "decay")
    c, a, s, w, p, misfit = damped_fit(t, u, crossings)
    measured = float(s / np.hypot(w, s))
    formula = float(traj.params["material"]["damping_ratio"])
    return measured, formula, (f"a damped sine fits the sway ({misfit:.1%} of its first "
                               f"swing off): {w / (2 * np.pi):.3f} Hz, its swings fall by "
                               f"{np.exp(-2 * np.pi * s / w):.3f} per period: damping ratio "
                               f"{measured:.4f}; the material's damping_ratio = {formula:g}")


def _sine(t, u, f):
    """Amplitude and phase [rad] of the sine at ``f`` [Hz] fitted (least squares, with an
    offset) to ``u`` at the times ``t``: ``u ~ c + A sin(2 pi f t + phase)``."""
    w = 2 * np.pi * f
    (a, b, _), *_ = np.linalg.lstsq(np.column_stack([np.sin(w * t), np.cos(w * t),
                                                     np.ones_like(t)]), u, rcond=None)
    return float(np.hypot(a, b)), float(np.arctan2(b, a))


def resonance(traj, last: float = 2.0):
    """The top's swing relative to its shaken base over the last ``last`` s (a sine at the
    drive frequency f fitted to each), against a single mass on a spring with its base shaken,
    ``r^2 / sqrt((1 - r^2)^2 + (2 zeta r)^2)`` (r = f / f0; 1 / (2 zeta) at resonance), times
    4 / pi (a shear beam's first mode at its top).  f0 is the material's
    ``damping_frequency``, which the lesson sets to the cube's damped sway frequency."""
    shakes = [h["shake"] for h in traj.params.get("handle", []) if "shake" in h]
    if not shakes:
        raise ValueError("the run shakes nothing: it needs the resonance lesson's run, "
                         "examples/lessons/resonance.toml (a [[handle]] with shake = {...})")
    f = float(shakes[0]["frequency"])
    amp = np.asarray(shakes[0]["amplitude"], dtype=float)
    ends = float(shakes[0].get("start", 0.0)) + float(shakes[0]["seconds"])
    if ends < traj.times[-1] - 1e-9 or not np.any(amp):
        raise ValueError(f"the shake ends at t = {ends:g} s, before the run's last {last:g} s "
                         f"that the measurement reads (or has no amplitude): shake for the "
                         f"whole run")
    mat = traj.params["material"]
    zeta, f0 = float(mat["damping_ratio"]), float(mat["damping_frequency"])
    t = np.asarray(traj.times) - traj.times[0]
    late = t > t[-1] - last
    x = np.asarray(traj.positions)[late] @ (amp / np.linalg.norm(amp))  # (along the shake)
    y0 = np.asarray(traj.rest_positions)[:, 1]
    base, top = y0 < y0.min() + 1e-3, y0 > y0.max() - 1e-3
    yb, pb = _sine(t[late], x[:, base].mean(axis=1), f)
    zt, pz = _sine(t[late], x[:, top].mean(axis=1) - x[:, base].mean(axis=1), f)
    lag = float(np.degrees((pb - pz) % (2 * np.pi)))
    r = f / f0
    single = r**2 / np.sqrt((1 - r**2) ** 2 + (2 * zeta * r) ** 2)
    formula = float(single * 4 / np.pi)
    measured = zt / yb
    lag_single = float(np.degrees(np.arctan2(2 * zeta * r, 1 - r**2)))
    return measured, formula, (f"shaken at {f:g} Hz (r = f / f0 = {r:.3f}, f0 = {f0:g} Hz) by "
                               f"{yb * 1e3:.3f} mm, the top swings {zt * 1e3:.2f} mm relative "
                               f"to the base ({measured:.2f} times), lagging it by {lag:.0f} "
                               f"deg; a single mass: {single:.2f} times, lagging by "
                               f"{lag_single:.0f} deg; times 4/pi for a shear beam's top: "
                               f"{formula:.2f} ({measured / formula - 1:+.1%})")


LESSONS = {"slide": slide, "incline": incline, "wobble": wobble, "decay": decay,
           "resonance": resonance}

if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] not in LESSONS:
        sys.exit(f"usage: python {sys.argv[0]} {{{','.join(LESSONS)}}} RUN_FOLDER")
    from jellysim import JellysimError, load_trajectory

    try:
        print(LESSONS[sys.argv[1]](load_trajectory(sys.argv[2]))[2])
    except JellysimError as exc:
        sys.exit(f"error: {exc} (run the lesson's scene first: its header gives the command)")
    except (ValueError, KeyError, RuntimeError) as exc:  # another lesson's run (a class slip)
        sys.exit(f"error: {sys.argv[2]}: {exc}" if isinstance(exc, ValueError) else
                 f"error: {sys.argv[2]} is not a run of the '{sys.argv[1]}' lesson "
                 f"({type(exc).__name__}: {exc}); run the lesson's scene: its header gives "
                 "the command")
