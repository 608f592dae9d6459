"""``jellysim export RUN -o table.csv``: the per-frame centre of mass, its velocity and the
energies, checked against an independent computation from the trajectory and against free
flight (no horizontal force: the centre of mass moves at the launch speed; gravity alone
changes its vertical velocity by -g t, whatever the springs do inside)."""
import numpy as np
import pytest
from click.testing import CliRunner

from jellysim.cli import cli
from jellysim.io.trajectory import load_trajectory
from jellysim.runner import run_scene
from jellysim.scene import Scene

SCENE = """
[body]
points = 64
lower = [0.0, 1.0, 0.0]
upper = [0.1, 1.1, 0.1]
seed = 4
velocity = [0.7, 0.4, -0.2]
[springs]
radius = 0.05
stiffness = 200.0
[mass]
point_mass = 0.001
[ground]
enabled = false
[integrator]
dt = 0.001
steps = 300
[output]
every = 20
vtu = false
"""


def test_the_table_is_the_trajectorys_centre_of_mass_and_energies(tmp_path):
    run_scene(Scene.from_text(SCENE, name="fly.toml"), tmp_path / "run", progress=False)
    res = CliRunner().invoke(cli, ["export", str(tmp_path / "run"), "-o",
                                   str(tmp_path / "table.csv")])
    assert res.exit_code == 0, res.output
    header = (tmp_path / "table.csv").read_text().splitlines()[0].split(",")
    assert header[:3] == ["time_s", "com_x_m", "com_y_m"] and "total_J" in header
    table = np.loadtxt(tmp_path / "table.csv", delimiter=",", skiprows=1)
    col = {name: table[:, k] for k, name in enumerate(header)}
    traj = load_trajectory(tmp_path / "run")
    m = traj.masses
    t = col["time_s"] - col["time_s"][0]
    assert len(t) == traj.frame_count == 16
    # an independent reading of the same frames
    com = np.einsum("n,fnd->fd", m, traj.positions) / m.sum()
    vel = np.einsum("n,fnd->fd", m, traj.velocities) / m.sum()
    for k, axis in enumerate("xyz"):
        np.testing.assert_allclose(col[f"com_{axis}_m"], com[:, k], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(col[f"com_v{axis}_m_per_s"], vel[:, k], rtol=1e-9,
                                   atol=1e-12)
    kinetic = 0.5 * np.einsum("n,fnd,fnd->f", m, traj.velocities, traj.velocities)
    np.testing.assert_allclose(col["kinetic_J"], kinetic, rtol=1e-9)
    # the highest point above the plate (y = 0 here, gravity along -y)
    np.testing.assert_allclose(col["top_height_m"], traj.positions[:, :, 1].max(axis=1),
                               rtol=1e-9, atol=1e-12)
    # free flight: momentum across g is kept, and gravity alone changes it along g
    np.testing.assert_allclose(col["com_vx_m_per_s"], 0.7, rtol=1e-9)
    np.testing.assert_allclose(col["com_vz_m_per_s"], -0.2, rtol=1e-9)
    g = -float(traj.gravity[1])  # (the report's 9.8 m/s^2 by default)
    assert g > 9
    np.testing.assert_allclose(col["com_vy_m_per_s"], 0.4 - g * t, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(col["travel_xz_m"], np.hypot(0.7, 0.2) * t, rtol=1e-6,
                               atol=1e-12)
    # the energy: symplectic Euler's free fall loses -1/2 M g^2 dt t (docs/physics.md), the
    # springs' wobble keeps its own to well below that
    np.testing.assert_allclose(col["total_J"] - col["total_J"][0],
                               -0.5 * m.sum() * g**2 * 0.001 * t, rtol=0.02, atol=1e-6)
    res = CliRunner().invoke(cli, ["export", str(tmp_path / "run"), "-o",
                                   str(tmp_path / "table.csv")])
    assert res.exit_code != 0 and "overwrite" in res.output  # (an existing table is kept)


def test_a_physical_runs_table_gives_its_tets_smallest_volume_ratio(tmp_path):
    """J = V / V0 of the tets, computed here from 3x3 determinants: 1 at rest, below 1 where
    the landing squeezes the cube.  A springs run's body with tets of its own (a random box's
    Delaunay tets) gets them too (the reliability trial: the CSV said NaN where `inspect`
    gave its tets' J, the sign of a folded spring body)."""
    scene = ('[material]\npreset = "gelatin"\n[body]\ntype = "box"\npoints = 27\n'
             'lower = [0.0, 0.02, 0.0]\nupper = [0.03, 0.05, 0.03]\n'
             '[integrator]\nsteps = 12\n[output]\nvtu = false\n')
    run_scene(Scene.from_text(scene, name="drop.toml"), tmp_path / "run", progress=False)
    traj = load_trajectory(tmp_path / "run")
    from jellysim.plot import diagnostics, write_table

    table = np.loadtxt(write_table(traj, tmp_path / "t.csv"), delimiter=",", skiprows=1)
    def smallest_j(x, run):
        t = np.asarray(run.tets)
        edges = lambda p: np.stack([p[t[:, k]] - p[t[:, 0]] for k in (1, 2, 3)], axis=1)
        return float(np.min(np.linalg.det(edges(x)) / np.linalg.det(edges(run.rest_positions))))

    expected = [smallest_j(x, traj) for x in traj.positions]
    np.testing.assert_allclose(table[:, -1], expected, rtol=1e-9)  # (10 digits written)
    assert expected[0] == 1.0 or abs(expected[0] - 1.0) < 1e-12
    assert min(expected) < 0.99  # (it landed: squeezed)
    springs = Scene.from_text(SCENE.replace("steps = 300", "steps = 20"), name="fly.toml")
    run_scene(springs, tmp_path / "fly", progress=False)
    fly = load_trajectory(tmp_path / "fly")
    assert not (fly.params or {}).get("fem") and len(fly.tets) > 0
    np.testing.assert_allclose(diagnostics(fly)["min_volume_ratio"],
                               [smallest_j(x, fly) for x in fly.positions], rtol=1e-12)


def test_a_straight_fall_s_sideways_panel_is_not_scaled_to_noise(tmp_path, monkeypatch):
    """Sweep trial, session 30: a cube falling straight down (here in free fall: its centre of
    mass moves sideways by rounding only, ~1e-16 m) had its sideways panel autoscaled to
    +-2e-16 m, so the noise looked like a drift.  That panel now spans at least 1e-4 of the
    body's size; a real sway keeps matplotlib's own scale."""
    import matplotlib.figure

    from jellysim.plot import plot_trajectory, sideways, diagnostics

    scene = ('[material]\npreset = "gelatin"\n[body]\ntype = "box"\npoints = 27\n'
             'lower = [0.0, 0.02, 0.0]\nupper = [0.03, 0.05, 0.03]\n'
             '[ground]\nenabled = false\n[integrator]\nsteps = 12\n[output]\nvtu = false\n')
    spans = []
    real = matplotlib.figure.Figure.savefig

    def keep_span(fig, *a, **k):
        spans.append(fig.axes[3].get_ylim())
        return real(fig, *a, **k)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", keep_span)
    for name, extra in (("straight", ""), ("sway", "velocity = [0.3, 0.0, 0.0]\n")):
        text = scene.replace("[ground]", extra + "[ground]")  # (into [body])
        run_scene(Scene.from_text(text, name=f"{name}.toml"), tmp_path / name, progress=False)
        traj = load_trajectory(tmp_path / name)
        plot_trajectory(traj, tmp_path / f"{name}.png")
        moved = max(float(np.abs(v).max()) for v in sideways(diagnostics(traj)).values())
        low, high = spans[-1]
        if name == "straight":
            assert moved < 1e-12 and (low, high) == pytest.approx((-3e-6, 3e-6))
        else:
            assert moved > 1e-3 and high - low < 4 * moved
