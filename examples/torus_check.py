"""Drop and free wobble of a body the tests do not use (the 8 cm torus of tests/data as a
marching gelatin body, E = 8 kPa), public API only: final height vs resting height, smallest
volume ratio, wobble frequency, periods visible, energy kept per period, real-time factors.

    PYTHONPATH=src python examples/torus_check.py
"""
import time
from pathlib import Path

import numpy as np

import jellysim as js
from jellysim.physics.fem import elastic_energy

MESH = str(Path(__file__).resolve().parents[1] / "tests" / "data" / "torus.obj")
GROUND = js.GroundParams(model=js.GroundModel.CONTACT)


def body(base_y):
    return js.Body.from_mesh(MESH, size=0.08, points=1500, connect="marching",
                             base=(0.0, base_y, 0.0))


def drop():
    mat = js.material("gelatin", youngs_modulus=8e3)
    rest = js.Simulator(js.physical_model(body(0.0), mat), dt=1 / 60, ground=GROUND)
    rest.advance(150)
    rest_top = float(rest.state.x[:, 1].max())
    sim = js.Simulator(js.physical_model(body(0.15), mat), dt=1 / 60, ground=GROUND)
    tops = []
    c0 = time.process_time()
    for _ in range(180):
        sim.advance(1)
        tops.append(float(sim.state.x[:, 1].max()))
    cpu = time.process_time() - c0
    top = float(np.mean(tops[-20:]))
    print(f"torus 8 cm, E 8 kPa, {sim.model.point_count} points, dropped 15 cm: final top "
          f"{top * 1e3:.2f} mm vs resting {rest_top * 1e3:.2f} mm "
          f"({(top / rest_top - 1) * 100:+.2f} %), min J {sim.min_tet_volume_ratio:.3f}, "
          f"substeps {sim.substeps}, real-time factor (CPU) {3.0 / cpu:.2f}x")


def wobble():
    """Undamped, gravity off, nothing held: started with an irrotational stretch (x out, y in,
    about the centre of mass: no net momentum), its amplitude along that shape over 2 s."""
    mat = js.material("gelatin", youngs_modulus=8e3, damping_ratio=0.0)
    model = js.physical_model(body(0.0), mat, gravity=(0.0, 0.0, 0.0))
    sim = js.Simulator(model, dt=1 / 60, ground=js.GroundParams(enabled=False))
    x0, m = model.point_x0, model.point_mass
    r = x0 - (m @ x0) / m.sum()
    shape = np.zeros_like(x0)
    shape[:, 0], shape[:, 1] = r[:, 0], -r[:, 1]
    sim.state.v[:] = 2.0 * shape
    u, e = [], []
    c0 = time.process_time()
    for _ in range(120):
        sim.advance(1)
        x = sim.state.x
        u.append(float(np.sum(m[:, None] * (x - x0) * shape) / np.sum(m[:, None] * shape**2)))
        e.append(0.5 * m @ np.sum(sim.state.v**2, axis=1) + elastic_energy(model.fem, x))
    cpu = time.process_time() - c0
    u = np.array(u) - np.mean(u)
    s = np.sign(u)
    up = np.flatnonzero((s[:-1] < 0) & (s[1:] >= 0))
    crossings = (up + u[up] / (u[up] - u[up + 1])) / 60
    f = 1 / np.median(np.diff(crossings))
    kept = (np.mean(e[-20:]) / np.mean(e[:20])) ** (1 / (2.0 * f))
    print(f"free wobble (undamped, gravity off): {f:.3f} Hz, {len(up)} upward crossings in 2 s, "
          f"energy kept per period {kept:.5f}, real-time factor (CPU) {2.0 / cpu:.2f}x")


if __name__ == "__main__":
    drop()
    wobble()
