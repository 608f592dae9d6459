"""The physical path's integrator candidates, measured on one wobble (issue 10, docs/physics.md).

The body of ``tests/test_physical_path.py``'s wobble test: a 10 cm gelatin cube (5^3 Kuhn grid,
216 points, 750 Stable Neo-Hookean tets, E = 10 kPa, nu = 0.48, no material damping, no
gravity), its base pinned, started in its fundamental shear shape (top at 5 cm/s), 2 s at
60 frames/s.  Candidates, each at the frame step dt = 1/60 s:

* ``symplectic``: the shipped one (symplectic Euler substeps counted from the stability
  estimate, :class:`jellysim.simulator.Simulator`);
* ``newton-euler``: backward Euler as the minimisation of the incremental potential
  ``|x - x_n - dt v_n|^2_M / (2 dt^2) + Psi(x)`` by Newton's method (Hessian-vector products by
  central differences of the compiled force kernel, unpreconditioned conjugate gradients, backtracking
  line search on the potential; stop at a gradient below 1e-4 of the inertial term; CG to
  1e-2 of the residual: an inexact Newton method);
* ``newton-midpoint``: the implicit midpoint rule ``M (v' - v) = dt f((x + x') / 2)``,
  ``x' = x + dt (v + v') / 2`` solved by Newton (same products, no potential: plain steps).

Printed per candidate: the wobble's frequency, the energy (kinetic + stored) kept per period,
and the force evaluations per frame (a substep, or one product = 2 evaluations, or one
residual) -- the cost unit that carries over to larger bodies, where the substep count grows
as 1 / spacing and unpreconditioned CG iterations grow alike.

    PYTHONPATH=src python -m benchmarks.bench_integrators [--seconds 2]

XPBD and Vertex Block Descent are not run: both are iterative solvers of the same implicit
Euler step (so they damp the wobble like ``newton-euler`` once converged, and are softer than
the material when not, docs/physics.md "Why not XPBD").
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
L, V0, DT = 0.1, 0.05, 1 / 60


def _cube():
    sys.path.insert(0, str(ROOT / "tests"))
    from bodies import kuhn_box
    from jellysim.physics.policy import physical_model
    from jellysim.presets import gelatin

    model = physical_model(kuhn_box((5, 5, 5), upper=(L, L, L)), gelatin(damping_ratio=0.0),
                           gravity=(0.0, 0.0, 0.0))
    y = model.point_x0[:, 1]
    return model, y < 1e-9, np.flatnonzero(y > L - 1e-9)


class _Forces:
    """Elastic forces [N] (n, 3) of the model's tets at x, counting evaluations."""

    def __init__(self, model):
        from jellysim.kernels import fem_numba

        self.k = fem_numba
        fem = model.fem
        self.q = np.zeros((fem.tet_count, 6))
        self.tup = fem.kernel_tuple(self.q, DT, damping=False)
        self.tf = np.zeros((4 * fem.tet_count, 3))
        self.tj = np.ones(fem.tet_count)
        self.n = model.point_count
        self.calls = 0

    def __call__(self, x):
        self.calls += 1
        out = np.zeros((self.n, 3))
        t = self.tup
        self.k.tet_forces(x, t, t[8], t[9], t[10], self.tf, self.tj)
        self.k.gather_tet_forces(self.tf, t[11], t[12], out)
        return out


def _newton_step(model, held, force, x, v, midpoint):
    from scipy.sparse.linalg import LinearOperator, cg

    from jellysim.physics.fem import elastic_energy

    m = model.point_mass[:, None]
    free = ~held
    xhat = x + DT * v
    scale = np.linalg.norm(m[free] * (DT * v[free])) / DT**2 + 1e-30

    def residual(y):
        if midpoint:
            r = 2.0 * m * (y - xhat) / DT**2 - force(0.5 * (x + y))
        else:
            r = m * (y - xhat) / DT**2 - force(y)
        r[held] = 0.0
        return r

    def potential(y):
        return 0.5 * np.sum(m * (y - xhat) ** 2) / DT**2 + elastic_energy(model.fem, y)

    y = xhat.copy()
    y[held] = x[held]
    for _ in range(20):
        r = residual(y)
        if np.linalg.norm(r) <= 1e-4 * scale:
            break
        at = 0.5 * (x + y) if midpoint else y
        eps = 1e-7 * L

        def hv(p, at=at):
            p = p.reshape(-1, 3).copy()
            p[held] = 0.0
            k = -(force(at + eps * p) - force(at - eps * p)) / (2 * eps)
            out = (2.0 if midpoint else 1.0) * m * p / DT**2 + (0.5 if midpoint else 1.0) * k
            out[held] = 0.0
            return out.ravel()

        op = LinearOperator((r.size, r.size), matvec=hv, dtype=np.float64)
        dx, _ = cg(op, -r.ravel(), rtol=1e-2, maxiter=200)
        dx = dx.reshape(-1, 3)
        step = 1.0
        if not midpoint:  # backtracking on the incremental potential
            p0 = potential(y)
            while step > 1e-4 and potential(y + step * dx) > p0:
                step *= 0.5
        y = y + step * dx
    vnew = (2.0 * (y - x) / DT - v) if midpoint else (y - x) / DT
    return y, vnew


def run(name, seconds):
    from jellysim.physics.fem import elastic_energy
    from jellysim.simulator import Simulator

    model, held, top = _cube()
    m = model.point_mass
    y0 = model.point_x0[:, 1]
    x = model.point_x0.copy()
    v = np.zeros_like(x)
    v[:, 0] = V0 * y0 / L
    frames = int(round(seconds / DT))
    sway, energy = [], []
    if name == "symplectic":
        sim = Simulator(model, dt=DT)
        sim.pin(np.flatnonzero(held))
        sim.state.v[:] = v
        for _ in range(frames):
            sim.advance(1)
            x, v = sim.state.x, sim.state.v
            sway.append(x[top, 0].mean() - model.point_x0[top, 0].mean())
            energy.append(0.5 * m @ np.sum(v**2, axis=1) + elastic_energy(model.fem, x))
        evals = sim.substeps
    else:
        force = _Forces(model)
        for _ in range(frames):
            x, v = _newton_step(model, held, force, x, v, name == "newton-midpoint")
            sway.append(x[top, 0].mean() - model.point_x0[top, 0].mean())
            energy.append(0.5 * m @ np.sum(v**2, axis=1) + elastic_energy(model.fem, x))
        evals = force.calls / frames
    u, e = np.array(sway), np.array(energy)
    s = np.sign(u)
    up = np.flatnonzero((s[:-1] < 0) & (s[1:] >= 0))
    t = (up + u[up] / (u[up] - u[up + 1])) * DT
    f = 1.0 / np.median(np.diff(t)) if len(t) > 1 else float("nan")
    periods = len(e) * DT * f
    kept = (e[-30:].mean() / e[:30].mean()) ** (1.0 / periods) if periods > 1 else float("nan")
    return {"integrator": name, "frequency_hz": round(float(f), 4),
            "energy_kept_per_period": round(float(kept), 5),
            "force_evaluations_per_frame": round(float(evals), 1)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0)
    args = ap.parse_args(argv)
    rows = [run(name, args.seconds) for name in ("symplectic", "newton-euler",
                                                   "newton-midpoint")]
    for r in rows:
        print(json.dumps(r), flush=True)


if __name__ == "__main__":
    main()
