"""Tetrahedral finite elements for the physical path: a material that does not invert.

A spring network lets points pass through their neighbours (nothing in it resists a tet turning
inside out), which is why soft spring bodies fold on impact.  Bodies with tets (Delaunay,
marching, TetGen and radius bodies) get, per tet, the **Stable Neo-Hookean** energy of
B. Smith, F. de Goes, T. Kim, "Stable Neo-Hookean Flesh Simulation", ACM TOG 37(2), 2018::

    Psi(F) = mu/2 (I_C - 3) + lam/2 (J - alpha)^2 - mu/2 log(I_C + 1),   alpha = 1 + 3 mu / (4 lam)

(``F``: deformation gradient, ``I_C = |F|^2``, ``J = det F``), which is defined and pushes back
for inverted tets (``J <= 0``) and whose volume term keeps volume.  Its parameters come from
Young's modulus and Poisson's ratio through the Lame constants with the paper's re-mapping
(section 3.4) ``mu = 4/3 mu_L``, ``lam = lam_L + 5/6 mu_L``, so that its linearisation at rest
*is* linear elasticity with (E, nu): tested against finite differences in tests/test_fem.py.

**Material damping** (:func:`damping_parameters`) is a standard linear solid in shear: a
Maxwell branch in parallel with the elastic law, its stress ``2 g mu_L dev(E_G - Q)`` a fraction
``g`` of the shear part of the linear law applied to the Green strain ``E_G`` minus an internal
strain ``Q`` per tet that relaxes towards ``E_G`` with time ``tau``.  A shear vibration then sees
the complex shear modulus ``mu_L (1 + g i w tau / (1 + i w tau))``: the loss factor
``tan d = g w tau / (1 + (1 + g) w^2 tau^2)``, the damping ratio of a mode ``zeta = tan d / 2``
(exactly so for a nearly incompressible body, whose vibrations store almost all their energy in
shear; volume changes are not damped).
``g`` and ``tau`` are chosen so that the loss factor peaks at the requested frequency with
``zeta`` there.  The branch is integrated exactly (``Q`` decays as ``exp(-dt / tau)``), so it
costs no stability; it is rotation invariant (Green strain), so rigid motion is never damped.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError

__all__ = ["FemArrays", "fem_arrays", "lame_parameters", "scale_light_masses", "snh_parameters",
           "damping_parameters"]


def lame_parameters(youngs_modulus: float, poisson_ratio: float) -> tuple[float, float]:
    """Lame constants ``(mu_L, lam_L)`` [Pa] of an isotropic linear material."""
    E, nu = float(youngs_modulus), float(poisson_ratio)
    return E / (2.0 * (1.0 + nu)), E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))


def snh_parameters(youngs_modulus: float, poisson_ratio: float) -> tuple[float, float, float]:
    """Stable Neo-Hookean ``(mu, lam, alpha)`` [Pa, Pa, -] whose linearisation at rest is the
    linear material with Young's modulus E [Pa] and Poisson's ratio nu (Smith et al. 2018,
    section 3.4)."""
    mu_l, lam_l = lame_parameters(youngs_modulus, poisson_ratio)
    mu = 4.0 / 3.0 * mu_l
    lam = lam_l + 5.0 / 6.0 * mu_l
    return mu, lam, 1.0 + 0.75 * mu / lam


def damping_parameters(zeta: float, frequency: float) -> tuple[float, float]:
    """Standard-linear-solid branch ``(g, tau)`` [-, s] whose damping ratio peaks at
    ``frequency`` [Hz] with the value ``zeta``.

    With ``s = sqrt(1 + g)`` the loss factor ``g w tau / (1 + s^2 w^2 tau^2)`` peaks at
    ``w tau = 1 / s`` with ``(s^2 - 1) / (2 s)``; setting that to ``2 zeta`` gives
    ``s = 2 zeta + sqrt(4 zeta^2 + 1)``.  ``zeta = 0`` gives ``(0, 0)`` (no branch).
    """
    zeta, frequency = float(zeta), float(frequency)
    if zeta == 0.0:
        return 0.0, 0.0
    s = 2.0 * zeta + math.sqrt(4.0 * zeta * zeta + 1.0)
    return s * s - 1.0, 1.0 / (2.0 * math.pi * frequency * s)


def loss_factor(frequency, g: float, tau: float):
    """Loss factor ``tan d`` [-] of the damping branch at ``frequency`` [Hz] (array or float);
    the damping ratio of a vibration at that frequency is half of it."""
    wt = 2.0 * np.pi * np.asarray(frequency, dtype=np.float64) * tau
    return g * wt / (1.0 + (1.0 + g) * wt * wt)


def storage_factor(frequency, g: float, tau: float):
    """Storage modulus at ``frequency`` [Hz] over the static modulus [-]: the branch stiffens
    fast vibrations by ``1 + g w^2 tau^2 / (1 + w^2 tau^2)``."""
    wt2 = (2.0 * np.pi * np.asarray(frequency, dtype=np.float64) * tau) ** 2
    return 1.0 + g * wt2 / (1.0 + wt2)


@dataclass(frozen=True, eq=False)
class FemArrays:
    """Per-tet data of the physical material, built once (read-only arrays, SI units).

    Each tet's force on its four corners is computed once into a per-tet buffer; every point
    then gathers its corners' entries through ``point_tet_ptr``/``point_tet_slot`` (a CSR list
    in tet order), so sums are race-free and in a fixed order.
    """

    tets: np.ndarray
    """Corner indices, shape (t, 4), int32, positively oriented at rest."""
    rest_inverse: np.ndarray
    """Inverse of the rest edge matrix ``[x1-x0, x2-x0, x3-x0]`` [1/m], shape (t, 3, 3)."""
    rest_volume: np.ndarray
    """Rest volumes [m^3], shape (t,), all > 0."""
    mu: np.ndarray
    """Stable Neo-Hookean mu [Pa], shape (t,)."""
    lam: np.ndarray
    """Stable Neo-Hookean lambda [Pa], shape (t,)."""
    alpha: np.ndarray
    """Rest-stability offset ``1 + 3 mu / (4 lam)`` [-], shape (t,)."""
    mu_lame: np.ndarray
    """Linear shear modulus [Pa], shape (t,): the damping branch's law."""
    lam_lame: np.ndarray
    """Linear Lame lambda [Pa], shape (t,)."""
    point_tet_ptr: np.ndarray
    """CSR offsets [-], shape (n + 1,), int64: the corner slots of point p are
    ``point_tet_slot[point_tet_ptr[p]:point_tet_ptr[p+1]]``."""
    point_tet_slot: np.ndarray
    """Corner slots ``4 t + c`` [-], shape (4 t,), int64, grouped by point, in tet order."""
    youngs_modulus: float
    """E [Pa]."""
    poisson_ratio: float
    """nu [-]."""
    damping_ratio: float
    """zeta [-] at ``damping_frequency``."""
    damping_frequency: float
    """Frequency [Hz] at which the damping ratio is ``damping_ratio``."""
    branch_ratio: float
    """Damping branch stiffness over the elastic stiffness ``g`` [-]."""
    branch_time: float
    """Damping branch relaxation time ``tau`` [s] (0: no branch)."""

    @property
    def tet_count(self) -> int:
        return int(self.tets.shape[0])

    def kernel_tuple(self, q: np.ndarray, dt: float, *, damping: bool = True) -> tuple:
        """The ``fem`` argument of :mod:`jellysim.kernels.fem_numba` /
        :mod:`~jellysim.kernels.fem_numpy` for substep ``dt`` [s], with the damping branch's
        strains ``q`` (shape (t, 6), updated in place); ``damping=False`` leaves the branch
        out (the rest stiffness)."""
        g, tau = (self.branch_ratio, self.branch_time) if damping else (0.0, 0.0)
        decay = float(np.exp(-dt / tau)) if tau > 0 else 0.0
        return (self.tets, self.rest_inverse, self.rest_volume, self.mu, self.lam, self.alpha,
                self.mu_lame, self.lam_lame, float(g), decay, q, self.point_tet_ptr,
                self.point_tet_slot)


def _frozen(a, dtype):
    a = np.ascontiguousarray(a, dtype=dtype)
    a.setflags(write=False)
    return a


def fem_arrays(points: np.ndarray, tets: np.ndarray, *, youngs_modulus: float,
               poisson_ratio: float, damping_ratio: float = 0.0,
               damping_frequency: float = 5.0) -> FemArrays:
    """Per-tet arrays for ``tets`` (shape (t, 4)) over rest ``points`` [m], shape (n, 3).

    Tets are oriented positively; degenerate ones (volume below 1e-12 of the mean) are refused.
    """
    p = np.asarray(points, dtype=np.float64)
    n = p.shape[0]
    t = np.asarray(tets, dtype=np.int64).reshape(-1, 4)
    if t.shape[0] == 0:
        raise ParameterError("the physical material needs tetrahedra; this body has none")
    if t.min() < 0 or t.max() >= n:
        raise ParameterError(f"tet indices must lie in [0, {n - 1}]")
    E, nu = float(youngs_modulus), float(poisson_ratio)
    if not (math.isfinite(E) and E > 0):
        raise ParameterError(f"youngs_modulus must be a positive number of Pa, got {youngs_modulus}")
    if not (-0.5 < nu < 0.5):
        raise ParameterError(f"poisson_ratio must lie in (-0.5, 0.5), got {poisson_ratio}")
    if not (math.isfinite(damping_ratio) and 0.0 <= damping_ratio < 1.0):
        raise ParameterError(f"damping_ratio must lie in [0, 1), got {damping_ratio}")
    if not (math.isfinite(damping_frequency) and damping_frequency > 0):
        raise ParameterError(f"damping_frequency must be a positive number of Hz, got "
                         f"{damping_frequency}")
    d = np.stack([p[t[:, c]] - p[t[:, 0]] for c in (1, 2, 3)], axis=2)  # columns: edges
    det = np.linalg.det(d)
    flip = det < 0
    t = t.copy()
    t[flip, 2], t[flip, 3] = t[flip, 3], t[flip, 2].copy()
    d[flip, :, 1], d[flip, :, 2] = d[flip, :, 2], d[flip, :, 1].copy()
    det = np.abs(det)
    if np.any(det <= 1e-12 * det.mean()):
        bad = int(np.argmin(det))
        raise ParameterError(f"tet {bad} is degenerate (volume {det[bad] / 6:.3g} m^3); rebuild "
                         "the body or drop slivers")
    inv = np.linalg.inv(d)
    vol = det / 6.0
    mu, lam, alpha = snh_parameters(E, nu)
    mu_l, lam_l = lame_parameters(E, nu)
    g, tau = damping_parameters(damping_ratio, damping_frequency)
    m = t.shape[0]
    corner = t.ravel()
    order = np.argsort(corner, kind="stable")
    ptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(corner, minlength=n), out=ptr[1:])
    full = lambda value: np.full(m, value)  # noqa: E731
    return FemArrays(
        tets=_frozen(t, np.int32), rest_inverse=_frozen(inv, np.float64),
        rest_volume=_frozen(vol, np.float64), mu=_frozen(full(mu), np.float64),
        lam=_frozen(full(lam), np.float64), alpha=_frozen(full(alpha), np.float64),
        mu_lame=_frozen(full(mu_l), np.float64), lam_lame=_frozen(full(lam_l), np.float64),
        point_tet_ptr=_frozen(ptr, np.int64), point_tet_slot=_frozen(order, np.int64),
        youngs_modulus=E, poisson_ratio=nu, damping_ratio=float(damping_ratio),
        damping_frequency=float(damping_frequency), branch_ratio=g, branch_time=tau)


def elastic_energy(fem: FemArrays, x: np.ndarray) -> float:
    """Stored Stable Neo-Hookean energy [J] of the tets at positions ``x`` [m], shape (n, 3)
    (zero at rest; the damping branch's energy is not included)."""
    t = fem.tets
    x0 = x[t[:, 0]]
    ds = np.stack([x[t[:, c]] - x0 for c in (1, 2, 3)], axis=2)
    F = ds @ fem.rest_inverse
    ic = np.einsum("tij,tij->t", F, F)
    J = np.linalg.det(F)
    mu, lam, alpha = fem.mu, fem.lam, fem.alpha
    psi = (0.5 * mu * (ic - 3.0) + 0.5 * lam * (J - alpha) ** 2
           - 0.5 * mu * np.log(ic + 1.0) + 0.5 * mu * np.log(4.0) - 0.5 * lam * (1.0 - alpha) ** 2)
    return float(np.sum(fem.rest_volume * psi))


def tet_stresses(fem: FemArrays, x: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
    """Cauchy (true) stress [Pa] of every tet at positions ``x`` [m] (n, 3): shape (t, 3, 3),
    symmetric, tension positive, ``sigma = P F^T / J`` with ``P`` the first Piola-Kirchhoff
    stress of the Stable Neo-Hookean energy (``kernels/fem_numpy.py``) plus, with the damping
    branch's internal strains ``q`` (t, 6) given, the branch's stress ``F g 2 mu_L dev(E_G -
    Q)`` (zero at rest).  A tet turned inside out (``J <= 0``) gets NaN: no true stress."""
    t = fem.tets
    x = np.asarray(x, dtype=np.float64)
    x0 = x[t[:, 0]]
    ds = np.stack([x[t[:, c]] - x0 for c in (1, 2, 3)], axis=2)
    F = ds @ fem.rest_inverse
    ic = np.einsum("tij,tij->t", F, F)
    c0, c1, c2 = F[:, :, 0], F[:, :, 1], F[:, :, 2]
    cof = np.stack([np.cross(c1, c2), np.cross(c2, c0), np.cross(c0, c1)], axis=2)
    J = np.einsum("ti,ti->t", c0, cof[:, :, 0])
    P = (fem.mu * (1.0 - 1.0 / (ic + 1.0)))[:, None, None] * F \
        + (fem.lam * (J - fem.alpha))[:, None, None] * cof
    if q is not None and fem.branch_ratio > 0.0:
        e = 0.5 * (np.einsum("tki,tkj->tij", F, F) - np.eye(3))
        d = e - _full_strain(np.asarray(q, dtype=np.float64))
        d -= (np.trace(d, axis1=1, axis2=2) / 3.0)[:, None, None] * np.eye(3)
        P = P + fem.branch_ratio * (F @ ((2.0 * fem.mu_lame)[:, None, None] * d))
    sigma = P @ np.transpose(F, (0, 2, 1))
    with np.errstate(divide="ignore", invalid="ignore"):
        sigma = np.where((J > 0.0)[:, None, None], sigma / J[:, None, None], np.nan)
    return 0.5 * (sigma + np.transpose(sigma, (0, 2, 1)))


def von_mises(sigma: np.ndarray) -> np.ndarray:
    """The von Mises equivalent stress [Pa] of Cauchy stresses ``sigma`` (..., 3, 3):
    ``sqrt(3/2 s:s)``, ``s`` the deviator (uniaxial tension sigma gives sigma)."""
    sigma = np.asarray(sigma, dtype=np.float64)
    s = sigma - (np.trace(sigma, axis1=-2, axis2=-1) / 3.0)[..., None, None] * np.eye(3)
    return np.sqrt(1.5 * np.einsum("...ij,...ij->...", s, s))


def stress_fields(sigma: np.ndarray, prefix: str = "") -> dict[str, np.ndarray]:
    """ParaView cell fields of Cauchy stresses ``sigma`` (t, 3, 3) [Pa]: ``von_mises`` (t,)
    [Pa] and ``stress`` (t, 9) [Pa], the tensor row by row (ParaView reads 9 components as a
    tensor), their names after ``prefix`` (``"elastic_"``: the elastic part alone, what a
    trajectory, without the damping branch's strain, can give)."""
    sigma = np.asarray(sigma, dtype=np.float64)
    return {f"{prefix}von_mises": von_mises(sigma),
            f"{prefix}stress": sigma.reshape(len(sigma), 9)}


def _full_strain(q: np.ndarray) -> np.ndarray:
    """(t, 6) strains (xx yy zz xy yz xz) as (t, 3, 3) symmetric tensors."""
    out = np.empty((len(q), 3, 3))
    for a, (i, j) in enumerate(((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))):
        out[:, i, j] = q[:, a]
        out[:, j, i] = q[:, a]
    return out


def scale_light_masses(mass: np.ndarray, fem: FemArrays, fraction: float) -> np.ndarray:
    """Point masses [kg], shape (n,), with ``fraction`` of the total moved onto the points that
    are lightest for their stiffness (selective nodal mass scaling; the total is kept).

    A point's highest frequency is bounded by its stiffness row over its mass: here
    ``k_i = sum over its tets of (lam + 2 mu) V |grad N_i| sum_j |grad N_j|`` (a Gershgorin
    bound of the rest stiffness, ``grad N`` the tet's shape-function gradients).  A few surface
    points of small tets have a large ``k_i / m_i`` and set the explicit substep
    (:mod:`jellysim.physics.stability_fem`).  A level ``w2`` is found by bisection such that
    raising every mass to ``k_i / w2`` adds ``fraction`` of the total, then all masses are
    scaled back to the original total.  Measured (session 8, gelatin, 10 cm meshes, marching):
    0.5 % lowers the largest frequency 1.2-2.3x on the sphere, Spot, Suzanne and the torus, by
    raising 40-380 points; ``fraction = 0`` returns ``mass`` unchanged.
    """
    mass = np.asarray(mass, dtype=np.float64)
    if fraction <= 0:
        return mass
    grad = np.empty((fem.tet_count, 4, 3))
    grad[:, 1:, :] = fem.rest_inverse
    grad[:, 0, :] = -fem.rest_inverse.sum(axis=1)
    norm = np.linalg.norm(grad, axis=2)
    row = ((fem.lam + 2.0 * fem.mu) * fem.rest_volume)[:, None] * norm * norm.sum(
        axis=1, keepdims=True)
    k = np.bincount(fem.tets.ravel(), weights=row.ravel(), minlength=len(mass))
    total = float(mass.sum())
    heavy = mass > 0
    if not heavy.any() or not np.any(k > 0):
        return mass
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):  # (absurd masses:
        lo, hi = 0.0, float(np.max(k[heavy] / mass[heavy]))  # refused by the substeps' count)
        for _ in range(100):  # the level w2 [1/s^2] at which the raised masses add `fraction`
            mid = 0.5 * (lo + hi)
            added = np.maximum(k / mid - mass, 0.0).sum() if mid > 0 else np.inf
            lo, hi = (mid, hi) if added > fraction * total else (lo, mid)
        scaled = np.maximum(mass, k / hi)
        return scaled * (total / scaled.sum())

