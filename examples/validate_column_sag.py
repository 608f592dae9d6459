"""Validation: a free-standing gelatin column sags under its own weight by rho g L^2 / (2 E).

A column of height L stands on a frictionless plate, its sides free.  Linear elasticity: the
stress at height y is rho g (L - y), the strain rho g (L - y) / E, so the top comes down by
rho g L^2 / (2 E), whatever Poisson's ratio.  The implicit integrator (backward Euler) at
dt = 1/60 s damps the drop to rest within a few seconds.

    PYTHONPATH=src python examples/validate_column_sag.py [--test]
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _physical import grid_body  # noqa: E402

from jellysim.params import GroundModel, GroundParams  # noqa: E402
from jellysim.presets import GELATIN_DENSITY  # noqa: E402
from jellysim.simulator import Simulator  # noqa: E402


def sag(cells_across, *, E=5e4, L=0.1, a=0.04, seconds=3.0):
    n_up = round(cells_across * L / a)
    model = grid_body((cells_across, n_up, cells_across), (0, 0, 0), (a, L, a),
                      youngs_modulus=E)
    ground = GroundParams(model=GroundModel.CONTACT, restitution=0.0, friction=0.0)
    sim = Simulator(model, dt=1 / 60, integrator="implicit", ground=ground)
    sim.advance(round(seconds * 60))
    top = model.point_x0[:, 1] > L - 1e-9
    return float(L - sim.state.x[top, 1].mean()), model.point_count


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--test", action="store_true", help="reduced size (CI)")
    args = ap.parse_args(argv)
    E, L = 5e4, 0.1
    expected = GELATIN_DENSITY * 9.8 * L**2 / (2 * E)
    rows = []
    for cells in ([2, 4] if args.test else [2, 4, 6, 8]):
        s, n = sag(cells, E=E, L=L)
        rows.append({"cells_across": cells, "points": n, "sag_m": s,
                     "expected_m": expected, "error": s / expected - 1})
    print(json.dumps(rows, indent=2))
    return rows


if __name__ == "__main__":
    main()
