"""Self-weight sag of a resting 10 cm gelatin cube built by the radius builder (issue 10).

    PYTHONPATH=src python -m benchmarks.bench_radius_sag [--points 2000 16000] [--seconds 4]
                                                         [--connect radius delaunay]

The cube [0, 0.1]^3 m (``cube.obj`` scaled), E = 10 kPa, 1141 kg/m^3, built by
``build_body(cube, points=N, connect=...)`` (radius: 24 neighbours on average, the default),
springs calibrated by ``calibrate_springs`` as a scene does, masses density x volume split
evenly (radius) or tet-lumped (Delaunay).  It rests on the contact ground (frictionless,
restitution 0) and the implicit integrator (backward Euler, dt = 1/60 s) settles it;
``--model fem`` instead puts the Stable Neo-Hookean material on the body's own tets (a radius
body's: Delaunay of its points, carved, slivers dropped) and settles it on the physical path
(symplectic substeps, damping ratio 0.3 so it comes to rest within a second).

Linear elasticity of a free-standing column: the point at height y comes down by
``u(y) = rho g (L y - y^2 / 2) / E`` (top: ``rho g L^2 / (2 E)``).  The sag ratio is
``sum d_i / sum u(y_i)`` over the points of the top tenth (``d_i``: their measured drop), so
points a little below the top count at their own height; 1 = the linear answer.  Three
figures: ``sag_ratio_top`` (drop relative to the lowest point, session 3's measure),
``sag_ratio_top_over_bottom_layer`` (relative to the mean of the points within half a spacing
of the bottom: a radius body has no flat bottom face and first sinks around its lowest
points), and ``static_linear_sag_ratio_top`` (the linear static equilibrium of the same
calibrated springs with that layer held vertically, :func:`static_sag_ratio`).  Also printed:
the tets the radius body now carries (their volume over the cube's, orphans, inverted).
Prints JSON.
"""
from __future__ import annotations

import argparse
import json
import os
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def cube_sag(points, connect, *, E=1e4, rho=1141.0, L=0.1, seconds=4.0, seed=0,
             surface_samples=None, model_name="springs"):
    from jellysim.build import build_body
    from jellysim.geometry import load_mesh
    from jellysim.geometry.mesh import Mesh
    from jellysim.geometry.tetra import tet_signed_volumes
    from jellysim.model import finalize
    from jellysim.params import GroundModel, GroundParams
    from jellysim.physics.material import calibrate_springs, point_masses
    from jellysim.simulator import Simulator

    cube = load_mesh(ROOT / "tests" / "data" / "cube.obj")  # [-1, 1]^3
    mesh = Mesh.from_arrays((cube.vertices + 1.0) * (L / 2), cube.faces, name="cube")
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        body = build_body(mesh, points=points, connect=connect, density=rho, seed=seed,
                          surface_samples=surface_samples)
    build_s = time.perf_counter() - t0
    masses = point_masses(body, rho) if body.masses is None else body.masses
    if connect == "radius" and body.masses is None:
        masses = np.full(body.point_count, rho * body.volume / body.point_count)
    t0 = time.perf_counter()
    body.stiffness = calibrate_springs(body, E)
    calib_s = time.perf_counter() - t0
    body.masses = masses
    ground = GroundParams(model=GroundModel.CONTACT, restitution=0.0, friction=0.0)
    if model_name == "fem":  # the body's tets, Stable Neo-Hookean, symplectic substeps
        from jellysim.params import Material
        from jellysim.physics.policy import physical_model

        model = physical_model(body, Material(youngs_modulus=E, density=rho, model="fem",
                                              damping_ratio=0.3), gravity=(0.0, -9.8, 0.0))
        sim = Simulator(model, dt=1 / 60, ground=ground)
    else:
        model = finalize(body, gravity=(0.0, -9.8, 0.0))
        sim = Simulator(model, dt=1 / 60, integrator="implicit", ground=ground)
    x0 = model.point_x0.copy()
    y0 = x0[:, 1] - x0[:, 1].min()
    t0 = time.perf_counter()
    sim.advance(round(seconds * 60))
    sim_s = time.perf_counter() - t0
    x = np.asarray(sim.state.x)
    drop = (x0[:, 1] - x0[:, 1].min()) - (x[:, 1] - x[:, 1].min())  # relative to the bottom
    top = y0 > 0.9 * (y0.max())
    u = rho * 9.8 * (L * y0 - 0.5 * y0**2) / E
    # the bottom layer (within half a spacing of the lowest point): a radius body has no flat
    # bottom face, so it first rests on a few low points and sinks around them; the column's
    # own sag is the top's drop relative to that layer
    layer = y0 < 0.5 * L / body.point_count ** (1 / 3)
    drop_layer = drop - drop[layer].mean()
    static = static_sag_ratio(body, masses, layer, E=E, rho=rho, L=L)
    row = {"connect": connect, "model": model_name,
           "surface_samples": bool(body.meta.get("surface_samples")),
           "requested_points": points, "points": body.point_count,
           "springs": body.spring_count, "sag_ratio_top": float(drop[top].sum() / u[top].sum()),
           "sag_ratio_top_over_bottom_layer": float(drop_layer[top].sum() / u[top].sum()),
           "static_linear_sag_ratio_top": static,
           "top_points": int(top.sum()), "expected_top_sag_m": rho * 9.8 * L**2 / (2 * E),
           "max_speed_end_m_per_s": float(np.linalg.norm(np.asarray(sim.state.v), axis=1).max()),
           "build_s": build_s, "calibrate_s": calib_s, "simulate_s": sim_s}
    if body.tets is not None and len(body.tets):
        sv = tet_signed_volumes(body.points, body.tets)
        covered = np.zeros(body.point_count, bool)
        covered[np.asarray(body.tets).ravel()] = True
        row.update(tets=int(len(body.tets)), tet_volume_over_cube=float(np.abs(sv).sum() / L**3),
                   inverted_tets=int(np.sum(sv <= 0)), points_in_no_tet=int((~covered).sum()))
    return row


def static_sag_ratio(body, masses, support, *, E, rho, L, g=9.8):
    """The same ratio for the linear static equilibrium of the calibrated springs
    (:func:`jellysim.physics.material.static_displacements`): ``K u = m g`` with the
    ``support`` points held vertically (frictionless)."""
    from jellysim.physics.material import static_displacements

    x = np.asarray(body.points, dtype=np.float64)
    f = np.zeros_like(x)
    f[:, 1] = -np.asarray(masses) * g
    held = np.zeros(x.shape, bool)
    held[support, 1] = True
    u = static_displacements(x, body.springs, body.stiffness, f, held)
    y0 = x[:, 1] - x[:, 1].min()
    top = y0 > 0.9 * y0.max()
    ua = rho * g * (L * y0 - 0.5 * y0**2) / E
    return float(-u[top, 1].sum() / ua[top].sum())


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, nargs="+", default=[2000, 16000])
    ap.add_argument("--connect", nargs="+", default=["radius", "delaunay"])
    ap.add_argument("--seconds", type=float, default=4.0)
    ap.add_argument("--model", choices=["springs", "fem"], default="springs",
                    help="springs (calibrated, implicit integrator) or fem (the body's tets on "
                         "the physical path, zeta 0.3 so it settles fast)")
    ap.add_argument("--surface-samples", action="store_true",
                    help="radius bodies with points on the surface (a flat bottom)")
    args = ap.parse_args(argv)
    rows = []
    for connect in args.connect:
        for n in args.points:
            rows.append(cube_sag(n, connect, seconds=args.seconds,
                                 surface_samples=True if args.surface_samples else None,
                                 model_name=args.model))
            print(json.dumps(rows[-1]), flush=True)
    print(json.dumps({"rows": rows, "cpu_count": os.cpu_count(),
                      "load_average_at_end": list(os.getloadavg())}, indent=2))


if __name__ == "__main__":
    main()
