"""Largest vibration frequency of a physical (FEM) body: what sets its explicit substep.

Power iteration on ``M^-1/2 K M^-1/2`` with ``K u`` from finite differences of the compiled
force kernels at rest (tets and springs): ``K u = -(f(x0 + eps u) - f(x0)) / eps``.  The
damping branch stiffens fast vibrations by ``1 + g``, so ``lambda_max`` is multiplied by it.
Symplectic Euler is stable for ``dt < 2 / omega_max`` (docs/physics.md).
"""
from __future__ import annotations

import numpy as np

__all__ = ["fem_omega_max"]


def _forces(model, x, out, scratch):
    from ..kernels import fem_numba as kn

    tet_force, tet_j, scalar, ft = scratch
    kn.tet_forces(x, ft, 0.0, 0.0, ft[10], tet_force, tet_j)
    kn.gather_tet_forces(tet_force, ft[11], ft[12], out)
    if model.spring_count and np.any(model.spring_stiffness != 0):
        springs = (model.spring_ij, model.spring_rest_length, model.spring_stiffness,
                   model.point_first_ptr, model.point_second_ptr, model.spring_second_slot,
                   model.point_second_other, True)
        kn._spring_forces(x, springs, scalar, out)


def fem_omega_max(model, *, iterations: int = 60, seed: int = 0) -> float:
    """Estimated largest angular frequency [rad/s] of the body at rest (5 % margin added)."""
    fem = model.fem
    x0 = np.array(model.point_x0)
    n = x0.shape[0]
    scratch = (np.zeros((4 * fem.tet_count, 3)), np.zeros(fem.tet_count),
               np.zeros(model.spring_count),
               fem.kernel_tuple(np.zeros((fem.tet_count, 6)), 1.0, damping=False))
    f0 = np.zeros((n, 3))
    f1 = np.zeros((n, 3))
    _forces(model, x0, f0, scratch)
    rs = np.sqrt(model.point_inv_mass)[:, None]
    y = np.random.default_rng(seed).standard_normal((n, 3))
    span = float(np.linalg.norm(x0.max(axis=0) - x0.min(axis=0)))
    lam = 0.0
    for _ in range(iterations):
        y /= np.linalg.norm(y)
        u = y * rs
        eps = 1e-7 * span / max(float(np.abs(u).max()), 1e-300)
        _forces(model, x0 + eps * u, f1, scratch)
        w = -(f1 - f0) / eps * rs
        lam = float(np.sum(y * w))
        y = w
    lam *= 1.0 + fem.branch_ratio
    return float(np.sqrt(max(lam, 0.0)) * 1.05)
