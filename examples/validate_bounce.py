"""Validation: bounces.  A point mass dropped from h rebounds to e^2 h (restitution e); a
gelatin cube dropped on a plate lands, bounces a little and settles.

Point mass: the contact model's closed form, checked for three restitutions with the explicit
symplectic integrator and with the implicit one.  Cube: 10 cm gelatin cube (preset constants)
dropped from ``--drop`` (default 2 cm); printed: the centre of mass's rebound after the first
landing, whether the base left the plate, and the time to settle (speed < 1 mm/s), for the
implicit integrator at dt = 1/60 s without and with substeps (less numerical damping).

    PYTHONPATH=src python examples/validate_bounce.py [--test] [--drop 0.02]
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _physical import grid_body  # noqa: E402

from jellysim.body import Body  # noqa: E402
from jellysim.model import finalize  # noqa: E402
from jellysim.params import GroundModel, GroundParams  # noqa: E402
from jellysim.simulator import Simulator  # noqa: E402


def point_rebound(e, integrator, *, h=0.5, dt=1e-4):
    body = Body(points=np.array([[0.0, h, 0.0]]), springs=np.zeros((0, 2), dtype=np.int64))
    model = finalize(body, point_mass=0.01)
    sim = Simulator(model, dt=dt, integrator=integrator,
                    ground=GroundParams(model=GroundModel.CONTACT, restitution=e))
    top, up = 0.0, False
    for _ in range(int(2.0 / dt)):
        sim.advance(1)
        vy = sim.state.v[0, 1]
        up |= vy > 0
        if up:
            top = max(top, sim.state.x[0, 1])
            if vy < 0:
                break
    return {"restitution": e, "integrator": integrator, "rebound_m": float(top),
            "expected_m": e * e * h, "error": float(top / (e * e * h) - 1)}


def cube_drop(cells, drop, substeps, *, seconds=2.0):
    L = 0.1
    model = grid_body((cells,) * 3, (0, drop, 0), (L, L + drop, L))
    ground = GroundParams(model=GroundModel.CONTACT, restitution=0.3, friction=0.6)
    sim = Simulator(model, dt=1 / 60, integrator="implicit", ground=ground, substeps=substeps)
    m = model.point_mass
    com, base, t = [], [], []
    for _ in range(round(seconds * 60)):
        sim.advance(1)
        com.append(float(m @ sim.state.x[:, 1] / m.sum()))
        base.append(float(sim.state.x[:, 1].min()))
        t.append(sim.state.t)
        if np.abs(sim.state.v).max() < 1e-3 and len(t) > 30:
            break
    com, base = np.array(com), np.array(base)
    landed = int(np.argmax(base <= 1e-9))
    low = landed + int(np.argmin(com[landed:]))
    rebound = float(com[low:].max() - com[low])
    lifted = bool(np.any(base[low:] > 1e-4))
    return {"cells": cells, "drop_m": drop, "substeps": substeps,
            "points": model.point_count, "com_rebound_m": rebound,
            "base_left_plate": lifted, "settled_after_s": t[-1],
            "final_height_m": float(sim.state.x[:, 1].max())}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--test", action="store_true", help="reduced size (CI)")
    ap.add_argument("--drop", type=float, default=0.02)
    args = ap.parse_args(argv)
    points = [point_rebound(e, "symplectic") for e in (0.3, 0.6, 0.9)]
    points.append(point_rebound(0.6, "implicit"))
    cells = 5 if args.test else 10
    cubes = [cube_drop(cells, args.drop, s) for s in ((1,) if args.test else (1, 4))]
    out = {"point_mass": points, "gelatin_cube": cubes}
    print(json.dumps(out, indent=2))
    return out


if __name__ == "__main__":
    main()
