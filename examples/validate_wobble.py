"""Validation: the fundamental wobble of a 10 cm gelatin cube on a plate, and the numerical
damping of the implicit integrator at a frame-rate time step.

The cube rests on the plate (friction holds its base) and is given the velocity of its first
shear mode, ``v_x = v0 sin(pi y / (2 L))``.  Estimate: a shear layer clamped at the base has
``f = (1 / (4 L)) sqrt(G / rho)``, ``G = E / (2 (1 + nu))`` with the network's nu = 1/4 (a
cube is no thin layer, so this is an estimate, not a closed form).  Reference: the explicit
symplectic integrator at a small dt (no numerical damping).  theta = 1/2 is listed to show
that it is not usable here: with contact at a frame-rate dt the linearised midpoint step gains
energy (docs/physics.md).  Measured per run: the wobble
frequency (zero crossings of the top's mean sideways displacement) and the fraction of the
wobble's energy kept per period (ratio of successive amplitude peaks, squared).

    PYTHONPATH=src python examples/validate_wobble.py [--test]
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


def wobble(cells, integrator, dt, *, theta=1.0, substeps=1, seconds=1.2, L=0.1, v0=0.05):
    model = grid_body((cells,) * 3, (0, 0, 0), (L, L, L))
    ground = GroundParams(model=GroundModel.CONTACT, restitution=0.0, friction=5.0)
    # settle first (backward Euler damps the sag quickly), then kick
    settle = Simulator(model, dt=1 / 60, integrator="implicit", ground=ground)
    settle.advance(90)
    state = settle.state
    state.v[:] = 0.0
    y = model.particle_x0[:, 1]
    state.v[:, 0] = v0 * np.sin(np.pi * y / (2 * L))
    if dt is None:
        dt = 0.5 * estimate_stability(model, "symplectic", 1.0).dt_max
    sim = Simulator(model, dt=dt, integrator=integrator, ground=ground, state=state,
                    substeps=substeps, implicit=ImplicitParams(theta=theta, tolerance=1e-6))
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
    peaks = [u[i] for i in range(1, len(u) - 1) if u[i] > u[i - 1] and u[i] >= u[i + 1]
             and u[i] > 0]
    kept = float(np.mean(np.square(np.array(peaks[1:]) / np.array(peaks[:-1])))) if len(
        peaks) > 1 else float("nan")
    return {"integrator": integrator, "theta": theta if integrator == "implicit" else None,
            "dt_s": dt, "substeps": substeps, "points": model.particle_count,
            "frequency_hz": float(f),
            "energy_kept_per_period": kept, "first_peak_m": float(peaks[0]) if peaks else None}


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
            wobble(cells, "implicit", 1 / 60, theta=1.0, substeps=4)]
    out = {"shear_layer_estimate_hz": float(estimate), "runs": rows}
    print(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
