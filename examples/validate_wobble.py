"""Validation: the fundamental wobble of a 10 cm gelatin cube on a plate, and the numerical
damping of the implicit integrator at a frame-rate time step.

The cube rests on the plate (friction holds its base) and is given the velocity of its first
shear mode, ``v_x = v0 sin(pi y / (2 L))``.  Estimate: a shear layer clamped at the base has
``f = (1 / (4 L)) sqrt(G / rho)``, ``G = E / (2 (1 + nu))`` with the network's nu = 1/4 (a
cube is no thin layer, so this is an estimate, not a closed form).  Reference: the explicit
symplectic integrator at a small dt (no numerical damping).  Implicit runs: backward Euler
(theta = 1), theta = 3/4 and 1/2, backward Euler with 4 substeps, and BDF2.  theta = 1/2 (the
midpoint step, energy-neutral in the linear closed form) measured 0.89 of the energy per
period in session 8, the inexact CG solve damping it (it gained energy in session 1's
version; docs/physics.md section 3).  Measured per run: the wobble
frequency (zero crossings of the top's mean sideways displacement) and the fraction of the
wobble's energy kept per period (from the amplitude envelope: the largest |u| in each whole
period, first to last, squared per period).

    PYTHONPATH=src python examples/validate_wobble.py [--test]

This is the springs path's check (the report's network, nu = 1/4).  The gelatin preset's
cube (the physical path, nu = 0.48) against a shear + bending estimate is a lesson:
examples/lessons/wobble.toml, docs/lessons.md.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _physical import grid_body, zero_crossing_frequency  # noqa: E402

from jellysim.params import GroundModel, GroundParams, ImplicitParams  # noqa: E402
from jellysim.presets import GELATIN_DENSITY, GELATIN_YOUNGS_MODULUS  # noqa: E402
from jellysim.simulator import Simulator  # noqa: E402
from jellysim.stability import estimate_stability  # noqa: E402


def closed_form_kept(scheme, theta, z, steps_per_period):
    """Energy a linear, undamped mode keeps per period (``z = omega dt``): theta-method
    ``((1 + (1 - theta)^2 z^2) / (1 + theta^2 z^2))^steps``; BDF2 ``|zeta|^(2 steps)`` with
    ``zeta = (2 + sqrt(1 + 2 i z)) / (3 - 2 i z)``, its principal root."""
    if scheme == "bdf2":
        zeta = (2 + np.sqrt(1 + 2j * z)) / (3 - 2j * z)
        return float(abs(zeta) ** (2 * steps_per_period))
    return float(((1 + (1 - theta) ** 2 * z * z) / (1 + theta**2 * z * z)) ** steps_per_period)


def wobble(cells, integrator, dt, *, theta=1.0, scheme="theta", substeps=1, seconds=1.2,
           L=0.1, v0=0.05):
    model = grid_body((cells,) * 3, (0, 0, 0), (L, L, L))
    ground = GroundParams(model=GroundModel.CONTACT, restitution=0.0, friction=5.0)
    # settle first (backward Euler damps the sag quickly), then kick
    settle = Simulator(model, dt=1 / 60, integrator="implicit", ground=ground)
    settle.advance(90)
    state = settle.state
    state.v[:] = 0.0
    y = model.point_x0[:, 1]
    state.v[:, 0] = v0 * np.sin(np.pi * y / (2 * L))
    if dt is None:
        dt = 0.5 * estimate_stability(model, "symplectic", 1.0).dt_max
    sim = Simulator(model, dt=dt, integrator=integrator, ground=ground, state=state,
                    substeps=substeps,
                    implicit=ImplicitParams(scheme=scheme, theta=theta, cg_tolerance=1e-6))
    top = y > L - 1e-9
    x_rest = state.x[top, 0].mean()
    every = max(1, round((1 / 240) / dt))
    t, u = [], []
    for _ in range(round(seconds / (every * dt))):
        sim.advance(every)
        t.append(sim.state.t)
        u.append(sim.state.x[top, 0].mean() - x_rest)
    t, u = np.array(t), np.array(u)
    f = zero_crossing_frequency(t, u)
    # energy kept per period: from the amplitude envelope, the largest |u| in each whole
    # period (robust to ripples of higher modes, which BDF2 and the symplectic reference keep)
    period = 1.0 / f
    windows = int((t[-1] - t[0]) // period)
    amp = [np.abs(u[(t >= t[0] + i * period) & (t < t[0] + (i + 1) * period)]).max()
           for i in range(windows)]
    kept = float((amp[-1] / amp[0]) ** (2.0 / (windows - 1))) if windows > 1 else float("nan")
    peaks = amp
    implicit = integrator == "implicit"
    closed = closed_form_kept(scheme, theta, 2 * np.pi * f * dt / substeps,
                              substeps / (f * dt)) if implicit else None
    return {"integrator": integrator, "scheme": scheme if implicit else None,
            "theta": theta if implicit and scheme == "theta" else None,
            "dt_s": dt, "substeps": substeps, "points": model.point_count,
            "frequency_hz": float(f),
            "energy_kept_per_period": kept, "closed_form_kept_per_period": closed, "first_peak_m": float(peaks[0]) if peaks else None}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--test", action="store_true", help="reduced size (CI)")
    args = ap.parse_args(argv)
    cells = 4 if args.test else 10
    E, nu = GELATIN_YOUNGS_MODULUS, 0.25
    estimate = np.sqrt(E / (2 * (1 + nu)) / GELATIN_DENSITY) / (4 * 0.1)
    rows = [wobble(cells, "symplectic", None),
            wobble(cells, "implicit", 1 / 60, theta=1.0),
            wobble(cells, "implicit", 1 / 60, theta=0.75),
            wobble(cells, "implicit", 1 / 60, theta=0.5),
            wobble(cells, "implicit", 1 / 60, theta=1.0, substeps=4),
            wobble(cells, "implicit", 1 / 60, scheme="bdf2")]
    out = {"shear_layer_estimate_hz": float(estimate), "runs": rows}
    print(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
