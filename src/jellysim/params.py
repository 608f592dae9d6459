"""Closed choices (Enums) and option records shared by the simulator, scenes and the CLI."""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from enum import Enum

from .errors import ParameterError

__all__ = [
    "Integrator",
    "ProvotPairs",
    "ProvotOrder",
    "ProvotParams",
    "GroundParams",
    "GroundModel",
    "ImplicitParams",
    "MAX_ALL_PAIRS_POINTS",
    "REPORT_DENSITY",
    "GRAVITY",
    "CONTACT_RESTITUTION",
    "CONTACT_FRICTION",
    "Material",
    "MaterialModel",
]

REPORT_DENSITY = 1141.0
"""Density of jello [kg/m^3] quoted by the report (section 6.4): the one default density of
jellysim (scenes, builders, :func:`~jellysim.model.finalize`, the gelatin preset)."""

GRAVITY = (0.0, -9.8, 0.0)
"""Default gravitational acceleration [m/s^2] (y up), the report's g = 9.8 m/s^2."""

CONTACT_RESTITUTION = 0.3
"""Default coefficient of restitution e [-] of the contact ground and of obstacles."""
CONTACT_FRICTION = 0.6
"""Default kinetic Coulomb friction coefficient [-] of the contact ground and of obstacles."""

CONTACT_SLIP_DISTANCE = 1.0e-3
"""Default slip-weakening distance D_c [m]: a contact point's friction coefficient falls from
the static to the kinetic one over this much slip, and is static again once the point sticks
(docs/physics.md section 2: with D_c = 0 a soft body's static friction was lost to the slip of
its base's edges)."""

MAX_ALL_PAIRS_POINTS = 4000
"""Largest body for ``ProvotPairs.ALL``: n (n - 1) / 2 = 8.0e6 pair checks per loop, about
10-50 ms per loop here.  Above this the O(n^2) hack is refused."""


class _Choice(str, Enum):
    """A named choice, matched whatever its case (``"SYMPLECTIC"`` is ``"symplectic"``:
    notebook trial, session 30)."""

    @classmethod
    def _missing_(cls, value):
        if isinstance(value, str):
            for member in cls:
                if member.value == value.strip().lower():
                    return member
        return None


class Integrator(_Choice):
    """Time integrators.

    ``PAPER``: the report's order (section 4.1): ``x += v dt; v += a dt; a = F(x, v) / m``.
    This is forward (explicit) Euler: without damping every vibration grows by a factor
    ``1 + (omega dt)^2`` in energy per step, so it is only stable with damping and
    ``dt < delta / (m omega_max^2)`` (the stability guard checks this).

    ``SYMPLECTIC``: semi-implicit Euler: ``a = F(x, v) / m; v += a dt; x += v dt``.
    Undamped it keeps energy bounded for ``dt < 2 / omega_max``.

    ``IMPLICIT``: the linearly implicit theta-method (:class:`ImplicitParams`; Baraff & Witkin
    1998 for theta = 1), a conjugate-gradient solve per step.  Unconditionally stable for the
    linearised system with theta >= 1/2; theta = 1/2 does not damp a linear vibration.
    See docs/physics.md.
    """

    PAPER = "paper"
    SYMPLECTIC = "symplectic"
    IMPLICIT = "implicit"


class GroundModel(_Choice):
    """Which ground rule acts at ``y = height``."""

    PAPER = "paper"
    """The report's rule (eqs. 2, 3): no normal force, no bounce."""
    CONTACT = "contact"
    """Non-penetration with restitution and Coulomb friction (:mod:`jellysim.physics.contact`)."""


class ProvotPairs(_Choice):
    """Which point pairs Provot strain limiting acts on."""

    SPRINGS = "springs"
    """Only the real springs (physically meaningful)."""
    ALL = "all"
    """Every point pair, rest length from the rest positions: the report's hack (section 4.1,
    5.2), O(n^2), refused above :data:`MAX_ALL_PAIRS_POINTS` points."""


class ProvotOrder(_Choice):
    """Order in which Provot corrections are applied within one loop."""

    JACOBI = "jacobi"
    """All corrections computed from the same positions, each point moved by the *average* of
    its corrections.  Parallel, independent of spring numbering, deterministic.  The default:
    an unaveraged Jacobi pass overshoots and diverges; the averaged one is stable."""
    GAUSS_SEIDEL = "gauss-seidel"
    """Springs processed one after another in index order, each correction applied at once.
    Converges in fewer loops but is sequential and depends on the spring order."""


@dataclass(frozen=True)
class ProvotParams:
    """Provot (1995) strain limiting (report section 4.1).

    A pair whose length leaves ``[(1 - tau) L0, (1 + tau) L0]`` (by more than 1e-12 L0,
    rounding noise) has both end points moved equally along the pair to the nearest bound,
    whatever their masses.  ``order``: ``"gauss-seidel"`` (the report's) applies the pairs one
    at a time; ``"jacobi"`` (the default) computes a pass's requests from the same positions,
    moves each point by the mean of its requests, then subtracts the moves' mass-weighted mean
    (a rigid translation, summed in a fixed order): a Jacobi pass conserves linear momentum to
    rounding, for any masses (a free 4-mass chain: below 2e-13 kg m/s after 1 s, where the
    mean alone gained 16.5 kg m/s in one step; docs/physics.md section 6,
    ``tests/test_provot_momentum.py``).  Neither order conserves angular momentum (a 1 kg
    dumbbell 1 m long spinning at 2 rad/s, k = 100 N/m, dt = 1 ms: L falls 1.84 % in 5 s).
    """

    enabled: bool = True
    tau: float = 0.001
    """Tolerance, a fraction of the rest length (0.001 = the report's 0.1 %)."""
    loops: int = 5
    """Passes per time step (report: 5 was sufficient; its benchmark used 1)."""
    pairs: ProvotPairs = ProvotPairs.SPRINGS
    order: ProvotOrder = ProvotOrder.JACOBI
    tolerance: float = 0.0
    """Stop the loops early once the largest point correction of a pass is below this [m]
    (0: always run ``loops`` passes)."""
    velocity_update: bool = True
    """After the position corrections, add (total correction) / dt to each point's velocity,
    as position-based dynamics does.  The report does not say; without it a point held up by
    Provot keeps the velocity it gained falling, and the body creeps through its own springs
    (try ``velocity_update = false`` on the paper cube: it flattens)."""

    def __post_init__(self):  # what a scene's [provot] table is checked for, in Python too
        for name, enum in (("pairs", ProvotPairs), ("order", ProvotOrder)):
            try:
                object.__setattr__(self, name, enum(getattr(self, name)))
            except ValueError:
                raise ParameterError(f"provot {name} must be one of {[e.value for e in enum]}, got "
                                 f"{getattr(self, name)!r}") from None
        _check_range("provot tau", self.tau, 0.0, 1.0, "a fraction of the rest length in "
                     "(0, 1)", open_low=True, open_high=True)
        if (isinstance(self.loops, bool) or not isinstance(self.loops, numbers.Integral)
                or self.loops < 1):
            raise ParameterError(f"provot loops must be an integer >= 1, got {self.loops!r}")
        _check_range("provot tolerance", self.tolerance, 0.0, float("inf"), "a distance >= 0 "
                     "[m]")


@dataclass(frozen=True)
class GroundParams:
    """The ground plane ``y = height`` [m], by one of two rules (``model``).

    ``GroundModel.PAPER`` (default): the report's ground (section 4.1, equations 2 and 3).  A
    point below the plane is put on it, its y velocity set to 0, its x and z velocities
    multiplied by ``mu``, and its y acceleration replaced by ``a_y - nu a_y``.  (Only the
    report's step, integrator ``"paper"``, uses that stored acceleration: the others compute
    it afresh from the forces, so ``nu`` changes nothing there.)

    ``GroundModel.CONTACT`` (what the physical path and the gelatin preset use): a contact
    with a coefficient of ``restitution``, Coulomb ``friction`` (``static_friction`` held
    until a point has slipped ``slip_distance``), or ``no_slip`` (docs/physics.md: the
    friction impulse never exceeds mu times the normal one within a step).  Each rule's
    parameters are refused with the other rule.
    """

    enabled: bool = True
    """Whether there is a ground at all."""
    mu: float = 0.1
    """Paper rule: factor [-] on the x/z velocity of a point on the ground (report eq. 2)."""
    nu: float = 0.2
    """Paper rule: acceleration factor [-] (report eq. 3: ``a_y - nu a_y``)."""
    height: float = 0.0
    """Height of the ground plane [m]."""
    model: GroundModel = GroundModel.PAPER
    """``PAPER`` (mu, nu above) or ``CONTACT`` (restitution and friction below)."""
    restitution: float = CONTACT_RESTITUTION
    """Contact model: coefficient of restitution e [-] (bounce speed / impact speed)."""
    friction: float = CONTACT_FRICTION
    """Contact model: kinetic Coulomb friction coefficient [-]."""
    static_friction: float | None = None
    """Contact model: static Coulomb friction coefficient [-] (default: ``friction``)."""
    slip_distance: float = CONTACT_SLIP_DISTANCE
    """Contact model: slip [m] over which a point's friction falls from static to kinetic."""
    no_slip: bool = False
    """Contact model: a point in contact never moves along the plane, whatever its normal
    force (a wet plate holding a gel by adhesion: Coulomb's bound vanishes at the base's edge,
    where the pressure does; the point can still lift off).  Explicit integrators only."""

    def __post_init__(self):
        for name in ("mu", "nu", "restitution"):  # (as a scene's [ground] is checked)
            _check_range(f"ground {name}", getattr(self, name), 0.0, 1.0, "a number in [0, 1]")
        _check_range("ground friction", self.friction, 0.0, float("inf"), "a number >= 0")
        if self.static_friction is not None:
            _check_range("ground static_friction", self.static_friction, 0.0, float("inf"),
                         "a number >= 0")
        _check_range("ground slip_distance", self.slip_distance, 0.0, float("inf"),
                     "a length >= 0 [m]")
        _check_range("ground height", self.height, -float("inf"), float("inf"), "a height [m]")
        try:
            object.__setattr__(self, "model", GroundModel(self.model))
        except ValueError:
            raise ParameterError(f"ground model must be one of {[m.value for m in GroundModel]}, "
                             f"got {self.model!r}") from None
        paper = {k: getattr(self, k) for k in ("mu", "nu")
                 if getattr(self, k) != _GROUND_DEFAULTS[k]}
        contact = {k: getattr(self, k) for k in ("restitution", "friction", "static_friction",
                                                  "slip_distance", "no_slip")
                   if getattr(self, k) != _GROUND_DEFAULTS[k]}
        if self.model is GroundModel.CONTACT and paper:
            raise ParameterError(f"ground {', '.join(f'{k} = {v}' for k, v in paper.items())}: "
                             "mu and nu are the report's paper ground's (model = 'paper'); the "
                             "contact ground's Coulomb coefficient is friction (and its bounce "
                             "restitution)")
        if self.model is GroundModel.PAPER and contact:
            raise ParameterError(f"ground {', '.join(f'{k} = {v}' for k, v in contact.items())}: "
                             "used by the contact ground only; give model = 'contact' (the "
                             "paper ground's rule has mu and nu)")


def _check_range(what, value, low, high, expected, *, open_low=False, open_high=False):
    """``value`` a finite real number within [low, high] (open ends where asked), else a
    ValueError naming ``what`` and the ``expected`` range."""
    ok = (not isinstance(value, bool) and isinstance(value, numbers.Real)
          and math.isfinite(value))
    if ok:
        ok = ((low < value) if open_low else (low <= value)) and (
            (value < high) if open_high else (value <= high))
    if not ok:
        raise ParameterError(f"{what} must be {expected}, got {value!r}")


_GROUND_DEFAULTS = {"mu": 0.1, "nu": 0.2, "restitution": CONTACT_RESTITUTION,
                    "friction": CONTACT_FRICTION, "static_friction": None,
                    "slip_distance": CONTACT_SLIP_DISTANCE, "no_slip": False}
""":class:`GroundParams`' defaults of each model's own keys (a key of the other model given
with a non-default value is refused)."""


class ImplicitScheme(_Choice):
    """Time discretisation of :attr:`Integrator.IMPLICIT` (see :class:`ImplicitParams`)."""

    THETA = "theta"
    """One-step theta-method (``theta = 1``: backward Euler)."""
    BDF2 = "bdf2"
    """Two-step backward differentiation formula (second order)."""


@dataclass(frozen=True)
class ImplicitParams:
    """Options of :attr:`Integrator.IMPLICIT`.

    ``scheme = "theta"``: one step solves
    ``(M + theta dt delta + theta^2 dt^2 K) dv = dt (F - theta dt K v)`` and sets
    ``x += dt (v + theta dv), v += dv``.  ``scheme = "bdf2"``: the second-order backward
    differentiation formula, linearised the same way with ``beta = 2 dt / 3``:
    ``(M + beta delta + beta^2 K) dv = M (v_n - v_n-1) / 3 + beta (F - K w)``,
    ``w = (x_n - x_n-1) / 3 + beta v_n``; ``x += (x_n - x_n-1) / 3 + beta (v + dv)``.
    """

    scheme: ImplicitScheme = ImplicitScheme.THETA
    """``THETA`` (one-step theta-method, ``theta`` below) or ``BDF2`` (two-step BDF2:
    second order, damps a vibration far less than backward Euler at the same dt: the 10 cm
    gelatin cube's 2.8 Hz wobble keeps 0.91 of its energy per period at dt = 1/60 s, 0.18 with
    backward Euler; ``theta`` is then unused).  Backward Euler is the robust one through
    impacts (a fine body dropped with BDF2 can fold): see docs/physics.md."""

    theta: float = 1.0
    """Implicitness in [1/2, 1]: 1 = backward Euler (the default: robust through impacts at
    a frame-rate dt, but it damps a vibration of angular frequency omega by
    ``(1 + (omega dt)^2)^-1/2`` per step); 1/2 = linearised implicit midpoint (no damping of
    a linear vibration, but the single linearised solve lets large, fast deformations gain
    energy).  See docs/physics.md for the measured damping."""
    cg_tolerance: float = 1e-3
    """Conjugate gradients stop when the residual is below this fraction of the right-hand
    side [-] (relative; ``ProvotParams.tolerance`` is a length)."""
    max_iterations: int = 300
    """Conjugate-gradient iterations per step at most."""

    def __post_init__(self):
        try:
            object.__setattr__(self, "scheme", ImplicitScheme(self.scheme))
        except ValueError:
            raise ParameterError(f"implicit scheme must be 'theta' or 'bdf2', got {self.scheme!r}") \
                from None
        if not 0.5 <= self.theta <= 1.0:
            raise ParameterError(f"implicit theta must lie in [0.5, 1], got {self.theta}")
        if not self.cg_tolerance > 0:
            raise ParameterError(f"implicit cg_tolerance must be > 0, got {self.cg_tolerance}")
        if not self.max_iterations >= 1:
            raise ParameterError(f"implicit max_iterations must be >= 1, got {self.max_iterations}")


class MaterialModel(_Choice):
    """How a body's elasticity is modelled on the physical path."""

    FEM = "fem"
    """Stable Neo-Hookean tetrahedra (:mod:`jellysim.physics.fem`): E and Poisson's ratio
    exact at small strain, resists inversion, keeps volume.  Needs tets."""
    SPRINGS = "springs"
    """The report's springs, each k derived from E (:mod:`jellysim.physics.material`):
    Poisson's ratio fixed at 1/4 by the Cauchy relation, nothing resists inversion."""


@dataclass(frozen=True)
class Material:
    """A real material for the physical path (SI units).  The defaults are the gelatin preset
    (:mod:`jellysim.presets`).

    ``damping_ratio`` is the fraction of critical damping of a vibration at
    ``damping_frequency`` (a standard linear solid, :func:`jellysim.physics.fem.
    damping_parameters`); vibrations at other frequencies see the solid's loss factor there
    (within 20 % of the peak between half and twice the frequency).
    """

    density: float = REPORT_DENSITY
    """[kg/m^3]."""
    youngs_modulus: float = 1.0e4
    """E [Pa]."""
    poisson_ratio: float = 0.48
    """nu [-], in (-0.5, 0.5) (FEM only; springs are 1/4).  Gelatin is nearly incompressible
    (~0.5); 0.48 is the lowest value measured that keeps a 5 kPa ball dropped 50 cm from
    inverting a tet (docs/physics.md) without locking the linear tets badly."""
    damping_ratio: float = 0.02
    """zeta [-] at ``damping_frequency`` (FEM only)."""
    damping_frequency: float = 5.0
    """[Hz]."""
    model: MaterialModel = MaterialModel.FEM
    mass_scaling: float = 0.005
    """Fraction of the body's mass [-], in [0, 0.05], moved onto the points that are lightest
    for their stiffness (FEM only; selective nodal mass scaling, as explicit crash codes do):
    a few surface points of small tets otherwise set the explicit substep.  0.5 % shortens the
    substeps per frame 1.2-2.3x on mesh bodies and moves the wobble frequency by < 0.5 %
    (:func:`jellysim.physics.fem.scale_light_masses`, docs/physics.md section 0); 0 keeps
    the tets' lumped masses."""

    def __post_init__(self):
        import math

        for name in ("density", "youngs_modulus", "poisson_ratio", "damping_ratio",
                     "damping_frequency", "mass_scaling"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, numbers.Real):
                raise ParameterError(f"material {name} must be a number, got {value!r} "
                                 f"({type(value).__name__})")
            narrow = getattr(getattr(value, "dtype", None), "itemsize", 8) < 8
            if narrow and not isinstance(value, numbers.Integral):  # a numpy float32:
                value = float(str(value))   # float32(0.05) is 0.05, as written
            object.__setattr__(self, name, float(value))
        checks = (("density", self.density > 0, "a positive number of kg/m^3"),
                  ("youngs_modulus", self.youngs_modulus > 0, "a positive number of Pa"),
                  ("poisson_ratio", -0.5 < self.poisson_ratio < 0.5, "in (-0.5, 0.5)"),
                  ("damping_ratio", 0 <= self.damping_ratio < 1, "in [0, 1)"),
                  ("damping_frequency", self.damping_frequency > 0, "a positive number of Hz"),
                  ("mass_scaling", 0 <= self.mass_scaling <= 0.05, "in [0, 0.05]"))
        for name, ok, allowed in checks:
            value = getattr(self, name)
            if not (math.isfinite(value) and ok):  # (numbers: checked above)
                raise ParameterError(f"material {name} must be {allowed}, got {value!r}")
        try:
            object.__setattr__(self, "model", MaterialModel(self.model))
        except ValueError:
            raise ParameterError(f"material model must be one of "
                             f"{[m.value for m in MaterialModel]}, got {self.model!r}") from None
        slip = density_slip(self.density)
        if slip:
            import warnings

            warnings.warn(f"material density {slip}", UserWarning, stacklevel=_user_stacklevel())
        if self.youngs_modulus < 100.0 or self.youngs_modulus > 1e9:
            import warnings

            warnings.warn(f"material youngs_modulus = {self.youngs_modulus:g} Pa is outside "
                          "100 Pa .. 1 GPa (gels are 1-100 kPa, rubber about 1 MPa): it is in "
                          "pascals (10 kPa = 1e4)", UserWarning, stacklevel=_user_stacklevel())


def density_slip(density: float) -> str | None:
    """What to say of a density [kg/m^3] outside 100 .. 25,000 (a likely slip of units: g/cm^3
    given as kg/m^3), else ``None``."""
    if 100.0 <= density <= 25000.0:
        return None
    return (f"= {density:g} kg/m^3 is outside 100 .. 25,000 kg/m^3 (gelatin 1141, water 1000, "
            "steel 7850): it is in kg/m^3 (1.141 would be g/cm^3)")


def _user_stacklevel() -> int:
    """The ``stacklevel`` for :func:`warnings.warn`, called in a jellysim function, that points
    at the first caller outside the jellysim package (the user's line).  (Here, not in
    :mod:`jellysim.errors`: both are leaf modules, importing nothing of ours.)"""
    import sys

    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_globals.get("__name__", "").startswith("jellysim"):
        frame, level = frame.f_back, level + 1
    return level
