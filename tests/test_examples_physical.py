"""The physical examples, run at reduced size (``--test``), and the gelatin scene."""
import sys
from pathlib import Path

import numpy as np
import pytest

from jellysim.errors import SceneError
from jellysim.scene import Scene

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "examples"))

RHO, G = 1141.0, 9.8


def test_column_sag_example_converges_to_closed_form(capsys):
    import validate_column_sag

    rows = validate_column_sag.main(["--test"])
    errors = [abs(r["error"]) for r in rows]
    assert all(e < 0.10 for e in errors)
    assert errors[1] < errors[0]  # finer is closer


def test_bounce_example(capsys):
    import validate_bounce

    out = validate_bounce.main(["--test"])
    for row in out["point_mass"]:
        assert abs(row["error"]) < 0.01
    cube = out["gelatin_cube"][0]
    assert cube["com_rebound_m"] > 1e-3  # it squashes and springs back up
    expected_top = 0.1 - RHO * G * 0.1**2 / (2 * 1e4)
    assert cube["final_height_m"] == pytest.approx(expected_top, rel=0.03)


def test_a_jello_ball_bounces_as_hertz_says(capsys):
    """A 6 cm, 10 kPa undamped gelatin ball (2,157 points) hits the frictionless ground at 3 cm/s
    with inelastic points: it bounces on its own elasticity (rebound > 0.98 v0: what it does not
    keep rings on as vibration), in contact for Hertz's t_c = 2.868 (m^2 / (R E*^2 v0))^(1/5)
    within 12 % (measured -8 %; -5.5 % from 5,000 to 17,000 points), its peak force and
    approach within 15 % (+8 %, -10 %): the tets' contact is about 20 % stiffer than the
    continuum's (docs/physics.md section 2).  A contact law or a material off by 2x in
    stiffness would move t_c by 25 %."""
    import validate_hertz

    (r,) = validate_hertz.main(["--test"])
    assert r["rebound"] > 0.98
    assert r["contact_time"] == pytest.approx(r["hertz_contact_time"], rel=0.12)
    assert r["peak_force"] == pytest.approx(r["hertz_peak_force"], rel=0.15)
    assert r["approach"] == pytest.approx(r["hertz_approach"], rel=0.15)


def test_wobble_example_frequency_and_measured_damping(capsys):
    import validate_wobble

    runs = validate_wobble.main(["--test"])["runs"]
    ref = runs[0]
    assert ref["integrator"] == "symplectic"
    assert 1.0 < ref["frequency_hz"] < 10.0  # "a believable few hertz"
    assert ref["energy_kept_per_period"] > 0.9  # the reference barely damps
    # theta = 1, 0.75, (0.5: not asserted), 1 x 4 substeps, BDF2
    be, theta75, _, be_sub4, bdf2 = runs[1:]
    for r in (be, theta75, be_sub4, bdf2):
        assert r["frequency_hz"] == pytest.approx(ref["frequency_hz"], rel=0.10)
    # numerical damping: less implicit or smaller steps, less of it; all of them damp
    assert be["energy_kept_per_period"] < theta75["energy_kept_per_period"] < 1.0
    assert be["energy_kept_per_period"] < be_sub4["energy_kept_per_period"] < 1.0
    # BDF2 at a frame-rate dt keeps the wobble: as much as the linear-mode closed form says
    # (~0.93 per period at 2.8 Hz), more than backward Euler with 4 substeps
    assert bdf2["energy_kept_per_period"] == pytest.approx(
        bdf2["closed_form_kept_per_period"], abs=0.05)
    assert bdf2["energy_kept_per_period"] > be_sub4["energy_kept_per_period"]


def test_gelatin_scene_settles_at_the_continuum_height():
    """The example is the physical path (FEM tets of its grid), damped hard so that it
    settles in 1.5 s.  Against the slender-column sag s = rho g L^2 / (2E) (5.6 mm; checked
    within 1 % on a hanging bar in test_physical_path.py): the top's corners sag less (the
    flat base cannot follow the Poisson bulge the 1D solution needs, nu rho g a^2 / (2E) ~
    0.7 mm over the half-width a; measured 3.94 mm, 0.70 s, on the example's mu = 0.6 plate,
    4.41 mm frictionless), the top's centre about as much (4.97 mm, 0.89 s: the plate's
    friction holds the base; 5.63 mm, 1.006 s, frictionless: docs/physics.md section 0)."""
    scene = Scene.load(ROOT / "examples" / "gelatin_cube.toml")
    assert scene.params["integrator"]["name"] == "symplectic"
    assert scene.params["ground"]["model"] == "contact"
    scene.params["material"]["damping_ratio"] = 0.3
    model = scene.build_model()
    assert model.fem is not None
    assert model.total_mass == pytest.approx(RHO * 0.1**3, rel=1e-9)
    sim = scene.simulator(model)
    sim.advance(90)
    s = RHO * G * 0.1**2 / (2 * scene.params["material"]["youngs_modulus"])
    sag = 0.1 - sim.state.x[:, 1].max()
    x0 = model.point_x0  # (dropped from 2 cm: its top starts at 0.12 m)
    top = x0[:, 1] > x0[:, 1].max() - 1e-9
    centre = top & (np.hypot(x0[:, 0] - 0.05, x0[:, 2] - 0.05) < 1e-9)
    assert centre.sum() == 1
    centre_sag = 0.1 - float(sim.state.x[centre, 1][0])
    print(f"sag: corners {sag * 1e3:.2f} mm, centre {centre_sag * 1e3:.2f} mm; slender-column "
          f"sag {s * 1e3:.2f} mm")
    assert 0.5 * s <= sag < centre_sag <= 1.05 * s
    assert centre_sag > 0.8 * s
    assert np.abs(sim.state.v).max() < 0.05  # at rest


def test_a_bare_gelatin_box_is_a_dessert_cube_on_the_physical_path():
    """``preset = "gelatin"`` with ``type = "box"`` and nothing else about the body: a 10 cm
    grid cube carrying its tets (not the report's 1 m random field, which needs a radius),
    so it rests like the example above: between half the slender-column sag and that sag.
    A radius named in the scene keeps the report's random field."""
    scene = Scene.from_text("[material]\npreset = 'gelatin'\n[body]\ntype = 'box'\n"
                            "points = 500\n[integrator]\nsteps = 90\n")
    b = scene.params["body"]
    assert b["distribution"] == "grid"
    assert (b["lower"], b["upper"]) == ([0.0, 0.0, 0.0], [0.1, 0.1, 0.1])
    scene.params["material"]["damping_ratio"] = 0.3
    model = scene.build_model()
    assert model.fem is not None
    assert np.ptp(model.point_x0, axis=0) == pytest.approx([0.1, 0.1, 0.1], rel=1e-12)
    assert model.total_mass == pytest.approx(RHO * 0.1**3, rel=1e-9)
    sim = scene.simulator(model)
    sim.advance(90)
    s = RHO * G * 0.1**2 / (2 * scene.params["material"]["youngs_modulus"])
    sag = 0.1 - sim.state.x[:, 1].max()
    assert 0.5 * s <= sag <= 1.05 * s
    for text in ("[body]\npoints = 500\n", "[body]\ndistribution = 'grid'\npoints = 500\n",
                 "[body]\ntype = 'box'\n"):  # type box is the default; so are 1000 points
        b = Scene.from_text("[material]\npreset = 'gelatin'\n" + text
                            + "[integrator]\nsteps = 1\n").params["body"]
        assert (b["distribution"], b["upper"]) == ("grid", [0.1, 0.1, 0.1])
        assert b["points"] == (1000 if "points" not in text else 500)
    bare = Scene.from_text("[material]\npreset = 'gelatin'\n")  # a whole scene: 3 s
    assert (bare.params["body"]["upper"], bare.steps) == ([0.1, 0.1, 0.1], 180)
    named = Scene.from_text("[material]\npreset = 'gelatin'\n[body]\ntype = 'box'\n"
                            "points = 500\n[springs]\nradius = 0.3\n[integrator]\nsteps = 9\n")
    assert named.params["body"]["distribution"] == "edge"
    assert named.params["body"]["upper"] == [1.0, 1.0, 1.0]


BASE = """
[body]
points = 30
lower = [0.0, 0.0, 0.0]
upper = [0.1, 0.1, 0.1]
[springs]
radius = 0.05
[integrator]
dt = 0.01
steps = 2
"""


def test_material_scene_errors():
    with pytest.raises(SceneError, match="youngs_modulus"):
        Scene.from_text(BASE)  # neither k nor E
    with pytest.raises(SceneError, match="both"):
        Scene.from_text(BASE.replace("radius = 0.05", "radius = 0.05\nstiffness = 2.0")
                        + "[material]\nyoungs_modulus = 1e4\n")
    with pytest.raises(SceneError, match="preset"):
        Scene.from_text(BASE + "[material]\npreset = 'jelly'\n")
    with pytest.raises(SceneError, match="implicit"):
        Scene.from_text(BASE.replace("[integrator]", "[integrator]\nname = 'implicit'")
                        + "[material]\npreset = 'gelatin'\n[provot]\nenabled = true\n")


def test_paper_preset_is_the_report_run():
    scene = Scene.from_text(BASE + "[material]\npreset = 'paper-2010'\n")
    p = scene.params
    assert p["springs"]["stiffness"] == 2.0 and p["physics"]["damping"] == 0.8
    assert p["provot"]["pairs"] == "all" and p["provot"]["loops"] == 1
    assert p["ground"]["model"] == "paper" and (p["ground"]["mu"], p["ground"]["nu"]) == (
        0.1, 0.2)
    assert p["integrator"]["name"] == "paper" and p["integrator"]["dt"] == 0.01  # the scene's


def test_paper_preset_example_is_the_spelled_out_paper_cube():
    a = Scene.load(ROOT / "examples" / "paper_2010_preset.toml").params
    b = Scene.load(ROOT / "examples" / "paper_cube.toml").params
    differ = {(s, k) for s in a for k in a[s] if a[s][k] != b[s][k]}
    # the preset name, the density given in [material] instead of [mass], the output cadence
    assert differ == {("material", "preset"), ("material", "density"), ("output", "every")}
    assert a["material"]["density"] == b["mass"]["density"]
