"""Stability guard: the largest stable time step of the explicit integrators.

Linearised about rest, the body's vibration frequencies are ``omega = sqrt(lambda)`` for the
eigenvalues ``lambda`` of ``M^-1/2 K M^-1/2`` (K: spring stiffness matrix).  For one mode with
damping rate ``c = delta / m`` the update matrices give (Jury's criterion):

* symplectic Euler: stable iff ``omega^2 dt^2 + 2 c dt < 4``, i.e.
  ``dt < 4 / (c + sqrt(c^2 + 4 omega^2))`` (= ``2 / omega`` undamped, ``2 / c`` with no springs);
* the report's order (forward Euler): stable iff ``dt < c / omega^2`` and ``c dt < 2``:
  *without damping it is unstable at every dt*; damping ``delta`` buys ``dt < delta / lambda_K``.

``lambda_max`` comes from power iteration on the rest stiffness for bodies up to
:data:`POWER_ITERATION_MAX_SPRINGS` springs, otherwise from a rigorous block-Gershgorin bound
``max_p sum_s k_s (1/m_p + 1/sqrt(m_p m_q))``.  The worst damping rate is used for each bound.

* the implicit theta-method (``Integrator.IMPLICIT``): for one mode the amplification factor
  has ``|A|^2 = (1 + (1 - theta)^2 z^2) / (1 + theta^2 z^2)`` (``z = omega dt``, undamped),
  which is <= 1 at every dt iff ``theta >= 1/2``: unconditionally stable for the linearised
  system; the implicit BDF2 scheme is A-stable (its principal root has modulus < 1).  The
  nonlinear step (rotating springs, contact) is guarded at run time by the non-finite/runaway
  check, and the simulator records how far each conjugate-gradient solve converged.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import SceneError
from .params import Integrator

__all__ = ["MAX_AUTO_SUBSTEPS", "StabilityEstimate", "estimate_stability", "max_eigenvalue",
           "springs_auto_substeps"]

POWER_ITERATION_MAX_SPRINGS = 2_000_000


@dataclass(frozen=True)
class StabilityEstimate:
    lambda_max: float
    """Largest eigenvalue of M^-1 K [1/s^2] (power iteration or Gershgorin bound)."""
    method: str
    """``"power-iteration"`` or ``"gershgorin"``."""
    dt_max: float
    """Largest linearly stable time step [s] (0 when no dt is stable)."""
    reason: str
    """Which limit sets ``dt_max``, in words."""

    @property
    def omega_max(self) -> float:
        """Highest angular frequency [rad/s]."""
        return float(np.sqrt(self.lambda_max))


def _stiffness_matvec(model, u):
    """K u for the rest stiffness (tangent stiffness at the rest positions)."""
    i = model.spring_ij[:, 0]
    j = model.spring_ij[:, 1]
    x = model.point_x0
    d = x[j] - x[i]
    length = np.linalg.norm(d, axis=1)
    nrm = d / np.where(length > 0, length, 1.0)[:, None]
    k = model.spring_stiffness
    du = u[j] - u[i]
    f = (k * np.einsum("ij,ij->i", nrm, du))[:, None] * nrm
    # geometric term for springs not at their rest length: k (1 - L0/L) (I - n n^T) du
    geo = k * (1.0 - model.spring_rest_length / np.where(length > 0, length, 1.0))
    if np.any(geo != 0):
        f += geo[:, None] * (du - np.einsum("ij,ij->i", nrm, du)[:, None] * nrm)
    out = np.zeros_like(u)  # becomes K u (the force is -K u)
    for c in range(3):
        out[:, c] = np.bincount(j, weights=f[:, c], minlength=len(u)) - np.bincount(
            i, weights=f[:, c], minlength=len(u))
    return out


def max_eigenvalue(model, *, iterations: int = 60, seed: int = 0) -> tuple[float, str]:
    """Largest eigenvalue of ``M^-1 K`` at rest [1/s^2] and the method used."""
    k = model.spring_count
    if k == 0 or not np.any(model.spring_stiffness > 0):
        return 0.0, "no-springs"
    m = model.point_mass
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        ratio = float(np.max(model.spring_stiffness)) / float(np.min(m))
    if not ratio < 1e250:  # (k / m beyond floating point: a near-zero mass, an absurd k)
        from .errors import SceneError

        raise SceneError(
            f"the springs' stiffness over the point masses is beyond floating point (largest "
            f"k {float(np.max(model.spring_stiffness)):.3g} N/m, smallest mass "
            f"{float(np.min(m)):.3g} kg): check [mass] density / point_mass (kg/m^3, kg) and "
            "[springs] stiffness (N/m)")
    if k > POWER_ITERATION_MAX_SPRINGS:
        i, j = model.spring_ij[:, 0], model.spring_ij[:, 1]
        cross = model.spring_stiffness / np.sqrt(m[i] * m[j])
        row = (np.bincount(i, weights=model.spring_stiffness, minlength=len(m))
               + np.bincount(j, weights=model.spring_stiffness, minlength=len(m))) / m
        row += np.bincount(i, weights=cross, minlength=len(m)) + np.bincount(
            j, weights=cross, minlength=len(m))
        return float(row.max()), "gershgorin"
    s = 1.0 / np.sqrt(m)[:, None]
    u = np.random.default_rng(seed).standard_normal((len(m), 3))
    lam = 0.0
    for _ in range(iterations):
        with np.errstate(over="ignore"):
            norm = np.linalg.norm(u)
        if not np.isfinite(norm):  # (k ~ 1e200: the squares overflow; their ratio does not)
            u = u / np.abs(u).max()
            norm = np.linalg.norm(u)
        if norm == 0:
            return 0.0, "power-iteration"
        u /= norm
        w = s * _stiffness_matvec(model, s * u)
        lam = float(np.sum(u * w))
        u = w
    # power iteration approaches from below; 5 % margin for the unconverged remainder
    return 1.05 * lam, "power-iteration"


def estimate_stability(model, integrator: Integrator, dt: float, *,
                       theta: float = 0.5, scheme: str = "theta") -> StabilityEstimate:
    """Largest stable dt for ``integrator`` on ``model`` (see module docstring)."""
    integrator = Integrator(integrator)
    lam, method = max_eigenvalue(model)
    if integrator is Integrator.IMPLICIT and scheme == "bdf2":
        return StabilityEstimate(lam, method, np.inf, "implicit BDF2: A-stable, unconditionally "
                                 "stable (linearised)")
    if integrator is Integrator.IMPLICIT:
        if theta >= 0.5:
            return StabilityEstimate(lam, method, np.inf,
                                     f"implicit theta = {theta:g} >= 1/2: unconditionally "
                                     "stable (linearised)")
        return StabilityEstimate(lam, method, 0.0 if lam > 0 else np.inf,
                                 f"implicit theta = {theta:g} < 1/2 amplifies undamped modes")
    inv_m = model.point_inv_mass
    c_max = model.damping * float(inv_m.max())
    c_min = model.damping * float(inv_m.min())
    damping_limit = 2.0 / c_max if c_max > 0 else np.inf
    if integrator is Integrator.SYMPLECTIC:
        if lam == 0 and c_max == 0:
            return StabilityEstimate(lam, method, np.inf, "no springs, no damping")
        spring_limit = 4.0 / (c_max + np.sqrt(c_max**2 + 4.0 * lam))
        reason = ("springs: omega_max^2 dt^2 + 2 (delta/m) dt < 4"
                  if spring_limit < damping_limit else "damping: delta dt / m < 2")
        return StabilityEstimate(lam, method, float(min(spring_limit, damping_limit)), reason)
    if lam == 0:
        return StabilityEstimate(lam, method, float(damping_limit), "damping: delta dt / m < 2")
    if c_min == 0:
        return StabilityEstimate(
            lam, method, 0.0,
            "the report's order is forward Euler: undamped springs grow at any dt")
    spring_limit = _forward_euler_limit(model, lam, c_min, c_max)
    if spring_limit < damping_limit:
        return StabilityEstimate(lam, method, float(spring_limit),
                                 "forward Euler: dt < (delta/m) / omega_max^2")
    return StabilityEstimate(lam, method, float(damping_limit), "damping: delta dt / m < 2")


def _forward_euler_limit(model, lam: float, c_min: float, c_max: float) -> float:
    """``dt < c / omega^2`` of the report's order for the body's fastest mode [s].

    With one damping rate ``c = delta / m`` this is ``c / lambda_max``.  With unequal masses the
    rates differ per point, and the fastest modes live on the light points (whose rate is the
    largest): each point p must damp its own frequency, ``c_p / lambda_p``, with ``lambda_p``
    its diagonal stiffness over mass ``sum_s k_s / m_p`` scaled so that the stiffest point's is
    ``lambda_max``.  (A 1e9 kg anchor holding a 0.5 kg bob, k = 20 N/m, delta = 0.2 N s/m: the
    closed form ``(delta / m_bob) / (k / m_bob) = 0.01 s``; the smallest rate over the
    largest lambda gave 4.8e-12 s.)"""
    if c_max == c_min:
        return c_min / lam
    i, j = model.spring_ij[:, 0], model.spring_ij[:, 1]
    k = model.spring_stiffness
    n = model.point_count
    diag = (np.bincount(i, weights=k, minlength=n) + np.bincount(j, weights=k, minlength=n)) * (
        model.point_inv_mass)
    rate = model.damping * model.point_inv_mass
    held = diag > 0
    local = diag[held] * (lam / float(diag.max()))
    return float(np.min(rate[held] / local))


def implicit_accuracy(omega_max: float, dt: float, *, theta: float = 1.0,
                      scheme: str = "theta") -> tuple[float, float, str]:
    """Accuracy of the implicit step for the body's highest mode (linearised, undamped).

    Returns ``(z, loss, words)``: ``z = omega_max dt`` (the mode is resolved when ``z`` is
    well below 1: fewer than ``2 pi / z`` steps per period otherwise), ``loss`` the fraction of
    that mode's amplitude the scheme removes per step (``1 - |A|``; theta method:
    ``|A|^2 = (1 + (1 - theta)^2 z^2) / (1 + theta^2 z^2)``; BDF2: the largest root of
    ``(3/2 - i z) r^2 - 2 r + 1/2 = 0``) and a sentence for messages."""
    z = float(omega_max) * float(dt)
    if scheme == "bdf2":
        roots = np.roots([1.5 - 1j * z, -2.0, 0.5])
        amp = float(np.max(np.abs(roots)))
        name = "BDF2"
    else:
        amp = float(np.sqrt((1 + (1 - theta) ** 2 * z * z) / (1 + theta * theta * z * z)))
        name = f"theta = {theta:g}"
    loss = 1.0 - amp
    if scheme != "bdf2" and theta < 0.5 and z > 0:
        return z, loss, (f"implicit {name} < 1/2: not stable for undamped modes (grows "
                         f"{-loss:.1%} per step at omega_max dt = {z:.3g}); use theta >= 1/2")
    if z == 0:
        words = f"implicit {name}: unconditionally stable; no spring mode to resolve"
    else:
        steps = 2 * np.pi / z
        words = (f"implicit {name}: unconditionally stable; accuracy: omega_max dt = {z:.3g} "
                 f"({steps:.3g} steps per period of the highest mode, "
                 f"{'resolved' if z < 1 else 'not resolved'}), which loses {loss:.1%} of its "
                 "amplitude per step")
    return z, loss, words


MAX_AUTO_SUBSTEPS = 10_000
"""``substeps = "auto"`` on the springs' symplectic path refuses to go beyond this."""


def springs_auto_substeps(model, dt) -> tuple[int, StabilityEstimate]:
    """Substeps of the springs' symplectic integrator for ``substeps = "auto"``: ``dt`` [s]
    over 0.9 of the estimated stable step (as the physical path counts its own; the report's
    ``paper`` integrator keeps one step per ``dt``), and the estimate."""
    est = estimate_stability(model, Integrator.SYMPLECTIC, float(dt))
    if not (est.dt_max > 0 and np.isfinite(est.dt_max)):
        return 1, est
    need = max(1, int(np.ceil(float(dt) / (0.9 * est.dt_max))))
    if need > MAX_AUTO_SUBSTEPS:
        raise SceneError(
            f"the springs are too stiff for dt = {float(dt):g} s: the symplectic integrator "
            f"would need {need if need < 1e9 else format(need, '.3g')} substeps per step "
            f"(stable limit {est.dt_max:.3g} s, "
            f"{est.reason}); soften them, use integrator = 'implicit', or for a tet body "
            "(connect = 'marching' or 'delaunay') the physical material "
            "([material] model = 'fem')")
    return need, est
