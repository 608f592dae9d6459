"""The table of scene keys (:data:`SCHEMA`): one :class:`~jellysim.scene_spec.Spec` per key,
its type, default, check and the words of its error.  A new key is one row here; the reading of
a scene is :mod:`jellysim.scene`, ``docs/scene.md`` is generated from this table
(``jellysim scene-help``).
"""
from __future__ import annotations

from .params import (GRAVITY, REPORT_DENSITY, GroundParams, ImplicitParams, Material,
                     ProvotParams)
from .kernels import Backend
from .scene_spec import REQUIRED, Spec, _nonneg, _pos

__all__ = ["SCHEMA"]

_P, _G, _I, _M = ProvotParams(), GroundParams(), ImplicitParams(), Material()
"""Defaults come from the option dataclasses (:mod:`jellysim.params`), the one source."""

SCHEMA: dict[str, dict[str, Spec]] = {
    "body": {
        "type": Spec("str", "box", "Where the body comes from: 'box' (a random field), 'mesh' "
                     "(points inside a surface mesh file) or 'file' (a .jello/.npz body); "
                     "left out with a path given: 'file' for .jello/.npz, else 'mesh'.",
                     choices=("box", "mesh", "file")),
        "path": Spec("str", None, "Mesh or body file (type 'mesh' / 'file'), relative to the "
                     "scene file.", lambda v: bool(v.strip()), allowed="a file name"),
        "points": Spec("int", None, "Number of points: of the random field (type 'box', "
                       "required) or sampled inside the mesh (type 'mesh', default 2000).  "
                       "A grid (distribution 'grid', the gelatin preset's box; connect "
                       "'marching' in a mesh) has about that many cells, so more points: "
                       "(N^(1/3) + 1)^3 for a box (1000: 1331).",
                       lambda v: v >= 2, "an integer >= 2 (>= 8 for a grid box)"),
        "sampling": Spec("str", "uniform", "Type 'mesh': how points are placed inside.",
                         choices=("uniform", "edge", "grid", "poisson")),
        "surface_samples": Spec("bool", None, "Type 'mesh', connect 'delaunay' or 'radius': "
                                "also put points on the surface (sharp edges, faces) a spacing "
                                "apart, so the body's surface lies on the mesh (default: on for "
                                "'delaunay', off for 'radius'; off: delaunay tetrahedralizes "
                                "the sampled points and the mesh vertices (the vertices our "
                                "addition), radius joins exactly `points` sampled inside, as "
                                "the report does).  A physical radius body wants "
                                "it on: without flat faces it rests on its lowest points."),
        "relax": Spec("int", None, "Type 'mesh', connect 'delaunay': Lloyd passes of the "
                      "sampled interior points before the tetrahedralization (default 10 with "
                      "surface samples, 0 without; 0 is the report's random points).  Relaxed "
                      "points make far fewer flat tets: fewer substeps and far fewer inverted "
                      "tets on hard drops (docs/physics.md section 0).", lambda v: v >= 0,
                      "an integer >= 0"),
        "rule": Spec("str", "auto", "Type 'mesh': the inside rule: 'parity' (a point inside "
                     "an odd number of shells: overlapping shells leave the overlap hollow, a "
                     "cavity stays one), 'winding' (any point the surface wraps: overlapping "
                     "shells are one solid), 'auto' (parity for closed meshes, winding for "
                     "open ones).", choices=("auto", "parity", "winding")),
        "size": Spec("float", None, "Type 'mesh': scale the mesh so its largest extent is this "
                     "[m].", lambda v: v > 0, "a number > 0 (m)"),
        "base": Spec("vec3", None, "Types 'mesh'/'file': move the body so the bottom centre of "
                     "its bounding box is here [m] (of its surface mesh when it has one: what "
                     "is drawn)."),
        "settle": Spec("bool", False, "Start at rest: before t = 0 the body settles under "
                       "gravity on its ground and obstacles (strongly damped, then the clock "
                       "set to 0), so a jello placed unsagged does not bounce through the run. "
                       "A `[[handle]]` force with no `until` is a load it settles under; one "
                       "with `until` acts from t = 0 only (off while settling); a pin "
                       "moving along a `path` or `shake` holds its points while settling and "
                       "moves from t = 0.  Physical path; serial runs."),
        "up": Spec("str", "y", "Type 'mesh': the mesh's axis that points up ('z' for most CAD "
                   "and STL files), turned to +y before size and base.",
                   choices=("y", "z", "x", "-y", "-z", "-x")),
        "distribution": Spec("str", "edge", "Random field: 'uniform' or the report's "
                             "edge-favouring (1 + cos(2 pi u)) / 2; or 'grid': a cubic lattice "
                             "of about that many cells, corners included (216: 7^3 points); "
                             "a box under the gelatin preset gets 'grid' and, without lower "
                             "and upper, the 10 cm cube [0, 0.1]^3 m (points 1000 unless "
                             "given), unless connect, radius or neighbours is given.",
                             choices=("uniform", "edge", "grid")),
        "lower": Spec("vec3", [0.0, 0.0, 0.0], "Lower box corner [m]."),
        "upper": Spec("vec3", [1.0, 1.0, 1.0], "Upper box corner [m]."),
        "seed": Spec("int", 0, "Random seed (same seed, same points).", lambda v: v >= 0,
                     "an integer >= 0"),
        "velocity": Spec("vec3", [0.0, 0.0, 0.0], "Initial velocity of every point [m/s]."),
    },
    "springs": {
        "connect": Spec("str", "radius", "Spring builder: 'radius' (report: implicit); for "
                        "type 'mesh' also 'marching', 'delaunay', 'tetgen' (a mesh body under "
                        "the gelatin preset gets 'marching' unless connect, radius or "
                        "neighbours is given).",
                        choices=("radius", "marching", "delaunay", "tetgen")),
        "radius": _pos("Connection radius r [m]: every pair at most r apart gets a spring "
                       "(type 'box': required, but 1.8 spacings for a grid; type 'mesh': "
                       "default from neighbours).", None,
                       unit=" (m)"),
        "neighbours": _pos("Type 'mesh', radius not given: target mean springs per point.",
                           24.0),
        "h": _pos("Type 'mesh', connect 'marching': cube edge [m] (default from points).", None,
                  unit=" (m)"),
        "snap": Spec("bool", None, "Type 'mesh', connect 'marching': warp the grid onto the "
                     "surface so the body fills the mesh (default); false keeps the "
                     "report's staircase: only the grid's tets whose corners are all inside, up "
                     "to a cell short of the surface (volumes: BENCHMARKS.md, "
                     "bench_marching_fill.py)."),
        "stiffness": Spec("float", None, "Spring stiffness k [N/m] (paper mode; give this or "
                          "[material] youngs_modulus).", lambda v: v > 0, "a number > 0 (N/m)"),
    },
    "material": {
        "preset": Spec("str", None, "Preset filling every key not given: 'gelatin' (real "
                       "gelatin: Stable Neo-Hookean tets, physical ground, symplectic substeps) "
                       "or 'paper-2010' (the report's "
                       "constants and hacks).", choices=("gelatin", "paper-2010")),
        "density": _pos("Density [kg/m^3]; point masses = density x the volume each point "
                        "owns (overrides [mass] density).", None, " (kg/m^3)"),
        "youngs_modulus": _pos("Young's modulus E [Pa] of a physical material: Stable "
                               "Neo-Hookean tets (model 'fem') or calibrated springs (model "
                               "'springs'), docs/physics.md.", None, " (Pa)"),
        "model": Spec("str", "auto", "Physical material model: 'fem' (tets that resist "
                      "inversion and keep volume; needs a tet body), 'springs' (the report's "
                      "springs, each k derived from E) or 'auto' (fem when the body has tets).",
                      choices=("auto", "fem", "springs")),
        "poisson_ratio": Spec("float", _M.poisson_ratio, "Poisson's ratio nu of the fem model "
                              "(gelatin: nearly incompressible).", lambda v: -0.5 < v < 0.5,
                              "a number in (-0.5, 0.5)"),
        "damping_ratio": Spec("float", _M.damping_ratio, "Fem model: fraction of critical "
                              "damping zeta of a vibration at damping_frequency (a standard "
                              "linear solid; the default is jellysim.Material()'s, gelatin's). "
                              "The branch also stiffens vibrations: the lesson cube's sway at "
                              "zeta 0.05 / 0.2 +5.1 / +26 % in frequency (docs/lessons.md).",
                              lambda v: 0 <= v < 1, "a number in [0, 1)"),
        "damping_frequency": _pos("Fem model: frequency [Hz] at which the damping ratio "
                                  "holds (the loss peak).", _M.damping_frequency, " (Hz)"),
        "mass_scaling": Spec("float", _M.mass_scaling, "Fem model: fraction of the body's mass "
                             "moved onto the points lightest for their stiffness (selective mass "
                             "scaling: fewer substeps; 0 keeps the tets' lumped masses).",
                             lambda v: 0 <= v <= 0.05, "a number in [0, 0.05]"),
    },
    "mass": {
        "density": _pos("Density [kg/m^3]; total mass = density x the body's volume: split "
                        "evenly over the points of box and radius bodies; tet bodies (connect "
                        "'marching', 'delaunay', 'tetgen') lump each tet's share on its corners.",
                        REPORT_DENSITY, " (kg/m^3)"),
        "point_mass": Spec("float", None, "Mass of every point [kg] (overrides density).",
                           lambda v: v > 0, "a number > 0 (kg)"),
    },
    "physics": {
        "damping": _nonneg("Velocity damping delta [kg/s] of every point (report eq. 1: the "
                           "force -delta v on each point, so a body of n points and mass M "
                           "has its velocity relax at the rate n delta / M [1/s]).", 0.0,
                           " (kg/s)"),
        "gravity": Spec("vec3", list(GRAVITY), "Gravitational acceleration [m/s^2].",
                        lambda v: sum(c * c for c in v) <= 1e12,
                        "three numbers, at most 1e6 m/s^2 long (Earth: [0, -9.8, 0])"),
    },
    "integrator": {
        "name": Spec("str", "symplectic", "'paper' (report order: x, v, then a), "
                     "'symplectic' (semi-implicit Euler) or 'implicit' (theta-method with a "
                     "conjugate-gradient solve, stiff-stable).",
                     choices=("paper", "symplectic", "implicit")),
        "dt": _pos("Time step [s].", unit=" (s)"),
        "steps": Spec("int", REQUIRED, "Number of time steps.", lambda v: v >= 1,
                      "an integer >= 1"),
        "backend": Spec("str", "numba", "Kernels: 'numba', 'numpy' (reference) or 'warp' "
                        "(NVIDIA Warp: a GPU, else Warp's CPU device; integrators 'paper' and "
                        "'symplectic'; pip install 'jellysim[gpu]').",
                        choices=tuple(b.value for b in Backend)),
        "device": Spec("str", "auto", "Warp device: 'auto' (a GPU when present, else the "
                       "CPU), 'cpu', 'cuda' or 'cuda:N' (backend = 'warp' only)."),
        "precision": Spec("str", "float64", "'float64' or 'float32': Warp arithmetic "
                          "(float64: bitwise the numba backend's on the CPU device); numba's "
                          "explicit step stores x, v, a in float32 and sums in float64.",
                          choices=("float64", "float32")),
        "threads": Spec("int", None, "Numba threads (default: 1 and all are timed as "
                        "the run goes, the faster kept, one on a tie).",
                        lambda v: v >= 1, "an integer >= 1"),
        "substeps": Spec("int", None, "Steps of dt / substeps per step (default, or 'auto': "
                         "what the stability estimate needs for 'symplectic'; 1 otherwise).",
                         lambda v: v >= 1, "an integer >= 1, or 'auto'", choices=("auto",)),
        "runaway_distance": _pos("A point farther than this [m] from the body's starting "
                                 "centre stops the run as a blow-up (default: 100 x the "
                                 "body's size, at least 100 m).", None, unit=" (m)"),
        "start_acceleration": Spec("str", "forces", "Accelerations at t = 0: 'forces' (from "
                                   "the forces at rest: gravity) or 'zero' (the report's "
                                   "code: a = 0 until the first force evaluation).",
                                   choices=("forces", "zero")),
        "scheme": Spec("str", _I.scheme, "Implicit: 'theta' (one step, see theta) or 'bdf2' "
                       "(two-step, second order: keeps a frame-rate wobble, 0.91 of its "
                       "energy per period at 2.8 Hz and dt = 1/60 s; less robust through "
                       "impacts).",
                       choices=("theta", "bdf2")),
        "theta": Spec("float", _I.theta, "Implicit: 1 = backward Euler (robust, damps), 0.5 = "
                      "midpoint (no damping of linear vibrations).", lambda v: 0.5 <= v <= 1,
                      "a number in [0.5, 1]"),
        "cg_tolerance": _pos("Implicit: relative residual at which CG stops.", _I.cg_tolerance),
        "cg_max_iterations": Spec("int", _I.max_iterations, "Implicit: CG iterations per step at most.",
                                  lambda v: v >= 1, "an integer >= 1"),
    },
    "provot": {
        "enabled": Spec("bool", _P.enabled, "Provot strain limiting on/off."),
        "tau": Spec("float", _P.tau, "Tolerance as a fraction of rest length (0.001 = 0.1 %).",
                    lambda v: 0 < v < 1, "a number in (0, 1)"),
        "loops": Spec("int", _P.loops, "Passes per step (report: 5).", lambda v: v >= 1,
                      "an integer >= 1"),
        "pairs": Spec("str", _P.pairs.value, "'springs' or 'all' (the report's O(n^2) hack).",
                      choices=("springs", "all")),
        "order": Spec("str", _P.order.value, "'jacobi' (parallel: each point moves by the mean "
                      "of its requests, then the pass's net move is taken out, so momentum is "
                      "kept) or 'gauss-seidel' (the report's: pair by pair, in order).",
                      choices=("jacobi", "gauss-seidel")),
        "tolerance": _nonneg("Stop the loops once the largest correction is below this [m].",
                             _P.tolerance, " (m)"),
        "velocity_update": Spec("bool", _P.velocity_update, "Add the correction / dt to the velocity."),
    },
    "ground": {
        "enabled": Spec("bool", _G.enabled, "The report's ground plane on/off."),
        "model": Spec("str", None, "'paper': the report's mu/nu rule (eqs. 2, 3), springs "
                      "path only; 'contact': non-penetration, restitution, Coulomb friction. "
                      "Default: 'paper' if mu or nu is given, 'contact' if restitution or "
                      "friction is, else 'contact' for a body on the physical (tet) path and "
                      "'paper' on the springs path.",
                      choices=("paper", "contact")),
        "height": Spec("float", _G.height, "Height of the plane y = height [m]."),
        "mu": Spec("float", _G.mu, "Factor on x/z velocity of a point on the ground.",
                   lambda v: 0 <= v <= 1, "a number in [0, 1]"),
        "nu": Spec("float", _G.nu, "Fraction of y acceleration removed on the ground (the "
                   "report's step, integrator 'paper', only: the others compute it afresh).",
                   lambda v: 0 <= v <= 1, "a number in [0, 1]"),
        "restitution": Spec("float", _G.restitution, "Contact: coefficient of restitution e of each point's impact (a free particle rebounds to e^2 h); a soft body's bounce is set by its material damping, hardly by e (docs/physics.md, \"Bounce and restitution\").",
                            lambda v: 0 <= v <= 1, "a number in [0, 1]"),
        "friction": _nonneg("Contact: kinetic Coulomb friction coefficient.", _G.friction),
        "static_friction": Spec("float", None, "Contact: static Coulomb coefficient "
                                "(default: friction).", lambda v: v >= 0, "a number >= 0"),
        "slip_distance": Spec("float", _G.slip_distance, "Contact: slip [m] over which a "
                              "point's friction falls from static to kinetic (it is static "
                              "again once the point sticks; docs/physics.md section 2).",
                              lambda v: v >= 0, "a length >= 0 (m)"),
        "no_slip": Spec("bool", False, "Contact: a point touching the ground never moves "
                        "along it (a wet plate holding a gel by adhesion; it can still lift "
                        "off); explicit integrators only."),
    },
    "output": {
        "every": Spec("int", None, "Steps between saved frames (default: about 100 frames, "
                      "and at least 60 per simulated second for a smooth video: every "
                      "step at dt = 1/60 s).",
                      lambda v: v >= 1, "an integer >= 1"),
        "vtu": Spec("bool", True, "Write the ParaView series body.pvd + one .vtu per frame."),
        "checkpoint_every": Spec("int", None, "Steps between checkpoints (checkpoint.npz, for "
                                 "'jellysim run --resume'), taken at the next saved frame; "
                                 "0: only when interrupted; default: at a frame once a "
                                 "minute of wall-clock time has passed.",
                                 lambda v: v >= 0, "an integer >= 0"),
    },
}
