"""One source for every default: the option dataclasses and constants of jellysim.params."""
import ast
from pathlib import Path

import numpy as np

import jellysim
from jellysim import params
from jellysim.scene import OBSTACLE_SCHEMA, SCHEMA

PKG = Path(jellysim.__file__).resolve().parent


def test_scene_schema_defaults_are_the_dataclass_defaults():
    P, G, I = params.ProvotParams(), params.GroundParams(), params.ImplicitParams()
    pv, gr, it = SCHEMA["provot"], SCHEMA["ground"], SCHEMA["integrator"]
    for key in ("enabled", "tau", "loops", "tolerance", "velocity_update"):
        assert pv[key].default == getattr(P, key), key
    assert pv["pairs"].default == P.pairs.value and pv["order"].default == P.order.value
    for key in ("enabled", "height", "mu", "nu", "restitution", "friction", "static_friction"):
        assert gr[key].default == getattr(G, key), key
    assert gr["model"].default is None  # unset: the body's path decides, the springs path's
    assert G.model.value == "paper"       # is the report's ground (test_hostile_input)
    assert (it["scheme"].default, it["theta"].default, it["cg_tolerance"].default,
            it["cg_max_iterations"].default) == (I.scheme, I.theta, I.cg_tolerance,
                                                 I.max_iterations)
    assert SCHEMA["mass"]["density"].default == params.REPORT_DENSITY
    assert tuple(SCHEMA["physics"]["gravity"].default) == params.GRAVITY
    from jellysim.physics.contact import Plane

    assert (OBSTACLE_SCHEMA["restitution"].default, OBSTACLE_SCHEMA["friction"].default) == (
        Plane().restitution, Plane().friction) == (G.restitution, G.friction)


def test_finalize_and_presets_use_the_one_density_and_gravity():
    from jellysim.presets import GELATIN_DENSITY, PRESETS

    body = jellysim.Body(points=np.eye(3), springs=np.array([[0, 1]]), volume=2.0)
    model = jellysim.finalize(body, stiffness=1.0)
    assert model.total_mass == params.REPORT_DENSITY * 2.0
    assert tuple(model.gravity) == params.GRAVITY
    assert GELATIN_DENSITY == params.REPORT_DENSITY
    assert PRESETS["gelatin"]["material"]["density"] == params.REPORT_DENSITY


def test_simulator_without_options_has_no_provot_and_no_ground_and_says_so():
    body = jellysim.Body(points=np.array([[0.0, 1, 0], [0.1, 1, 0]]), springs=np.array([[0, 1]]))
    model = jellysim.finalize(body, stiffness=1.0, point_mass=0.1)
    sim = jellysim.Simulator(model, dt=1e-3, check_stability=False)
    assert not sim.provot.enabled and not sim.ground.enabled
    on = jellysim.Simulator(model, dt=1e-3, provot=jellysim.ProvotParams(),
                            ground=jellysim.GroundParams(), check_stability=False)
    assert on.provot == params.ProvotParams() and on.provot.enabled and on.ground.enabled


def _numbers(tree):
    for n in ast.walk(tree):
        if isinstance(n, ast.Constant) and isinstance(n.value, float):
            yield n.value, n.lineno


def test_density_gravity_and_contact_defaults_are_written_once():
    """1141 kg/m^3, g = 9.8 m/s^2 and the contact defaults 0.3 / 0.6 appear as numbers only in
    jellysim/params.py (comments and docstrings may quote them)."""
    watched = {1141.0: [], 9.8: [], -9.8: []}
    for f in sorted(PKG.rglob("*.py")):
        for value, line in _numbers(ast.parse(f.read_text(encoding="utf-8"))):
            if value in watched:
                watched[value].append(f"{f.relative_to(PKG).as_posix()}:{line}")
    assert [w.split(":")[0] for w in watched[1141.0]] == ["params.py"], watched[1141.0]
    assert [w.split(":")[0] for w in watched[9.8] + watched[-9.8]] == ["params.py"], watched
