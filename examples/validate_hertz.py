"""Validation: a jello ball's impact against Hertz's closed form.

A 6 cm gelatin ball (E = 10 kPa, nu = 0.48, undamped, a marching body of an icosphere) moves
at v0 onto the frictionless contact ground, gravity off, its points inelastic (restitution
0): the bounce comes from the ball's own elasticity.  Hertz's quasi-static impact of an elastic
sphere (mass m, radius R) on a rigid plane, with ``E* = E / (1 - nu^2)``::

    contact time   t_c   = 2.868 (m^2 / (R E*^2 v0))^(1/5)
    largest approach d    = (15 m v0^2 / (16 E* R^(1/2)))^(2/5)
    peak force     F_max = 4/3 E* R^(1/2) d^(3/2)

(Johnson, Contact Mechanics, 1985, section 11.4).  Measured from the ball's momentum P at
4,000 frames/s: the contact force ``dP/dt``, the contact time (first to last frame with any
contact impulse), the centre of mass's largest approach, and the rebound speed.  The built
body is turned by a fixed generic rotation first: a marching grid is aligned with the body's
bounding box, and at some resolutions its pole, where the ball would land, is a flat patch
(16,927 points: 8 surface points within 0.05 mm of the lowest over a 4.7 mm radius, 0.38 mm
above the sphere's pole), which made the contact 20 % shorter.  docs/physics.md section 2
quotes the output.

    PYTHONPATH=src python examples/validate_hertz.py [--test]
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import warnings

import numpy as np

import jellysim as js

R = 0.03
"""[m] The ball's radius."""

FPS = 4000
"""[1/s] Frames per second of the measurement."""


def hertz(mass, youngs_modulus, poisson_ratio, v0):
    """Hertz's contact time [s], largest approach [m] and peak force [N] (docstring above)."""
    es = youngs_modulus / (1.0 - poisson_ratio**2)
    t_c = 2.868 * (mass**2 / (R * es**2 * v0)) ** 0.2
    d = (15.0 * mass * v0**2 / (16.0 * es * np.sqrt(R))) ** 0.4
    return t_c, d, 4.0 / 3.0 * es * np.sqrt(R) * d**1.5


def impact(points, v0, *, youngs_modulus=1e4, poisson_ratio=0.48):
    """One impact: a dict of the measured and Hertz values (SI units)."""
    import trimesh
    from scipy.spatial.transform import Rotation

    sphere = trimesh.creation.icosphere(subdivisions=5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # (a marching body's volume share: not used here)
        body = js.Body.from_mesh((sphere.vertices, sphere.faces), size=2 * R, points=points,
                                 base=(0.0, 0.001, 0.0))
    centre = body.points.mean(axis=0)
    turned = Rotation.from_rotvec([0.37, 0.0, 0.61]).apply(body.points - centre) + centre
    body = dataclasses.replace(body, points=turned)
    mat = js.material("gelatin", youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio,
                      damping_ratio=0.0)
    model = js.physical_model(body, mat, gravity=(0.0, 0.0, 0.0))
    sim = js.Simulator(model, dt=1.0 / FPS, threads=1, ground=js.GroundParams(
        model="contact", friction=0.0, restitution=0.0))
    sim.state.x[:, 1] -= sim.state.x[:, 1].min() - 1e-9
    sim.state.v[:, 1] = -v0
    m = model.point_mass
    mass = float(m.sum())
    t_c, d, f_max = hertz(mass, youngs_modulus, poisson_ratio, v0)
    p, y = [-mass * v0], [float(m @ sim.state.x[:, 1]) / mass]
    for _ in range(int(3 * t_c * FPS)):
        sim.advance(1)
        p.append(float(m @ sim.state.v[:, 1]))
        y.append(float(m @ sim.state.x[:, 1]) / mass)
    force = np.diff(p) * FPS
    on = np.flatnonzero(force > 1e-6 * force.max())
    return {"points": model.point_count, "v0": v0, "mass": mass,
            "contact_time": (on[-1] - on[0] + 1) / FPS, "hertz_contact_time": t_c,
            "peak_force": float(force.max()), "hertz_peak_force": f_max,
            "approach": y[0] - min(y), "hertz_approach": d, "rebound": p[-1] / (mass * v0)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--test", action="store_true", help="one small run (the test suite's)")
    args = ap.parse_args(argv)
    runs = ([(2000, 0.03)] if args.test else
            [(p, 0.03) for p in (2000, 5000, 9000, 16000)] + [(9000, 0.1), (9000, 0.3)])
    out = []
    for points, v0 in runs:
        r = impact(points, v0)
        out.append(r)
        if not args.test:
            print(f"{r['points']:6d} points, v0 {v0:4.2f} m/s: contact {r['contact_time']*1e3:6.1f}"
                  f" ms (Hertz {r['hertz_contact_time']*1e3:6.1f}), peak force "
                  f"{r['peak_force']:.3f} N ({r['hertz_peak_force']:.3f}), approach "
                  f"{r['approach']*1e3:.3f} mm ({r['hertz_approach']*1e3:.3f}), rebound "
                  f"{r['rebound']:.3f} v0", flush=True)
    if args.test:
        print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
