"""A drop and a free wobble of gelatin bodies that no test uses, through the public API:
final vs resting height, wobble frequency and periods, energy kept per period, real-time
factor.  Run from the repository root: ``PYTHONPATH=src python examples/motion_check.py``."""
import time, numpy as np, warnings
import jellysim as js
from jellysim.physics.fem import elastic_energy
warnings.simplefilter("ignore")
G = js.GroundParams(model=js.GroundModel.CONTACT)
# 1. drop: a 5 cm gelatin ball (sphere.obj, marching, 800 points), 10 kPa, zeta 0.1
def ball(drop):
    body = js.Body.from_mesh("tests/data/sphere.obj", size=0.05, points=800, connect="marching",
                             base=(0.0, drop, 0.0))
    model = js.physical_model(body, js.material("gelatin", damping_ratio=0.1))
    sim = js.Simulator(model, dt=1/60, threads=1, ground=G)
    tops, c = [], time.process_time()
    for _ in range(150):
        sim.advance(1); tops.append(sim.state.x[:, 1].max())
    return np.array(tops), sim, time.process_time() - c
rest, _, _ = ball(0.0)
top, sim, cpu = ball(0.10)
print(f"drop 10 cm: final top {top[-30:].mean()*1000:.2f} mm vs resting {rest[-30:].mean()*1000:.2f} mm "
      f"({top[-30:].mean()/rest[-30:].mean()-1:+.2%}); min J {sim.min_tet_volume_ratio:.3f}; "
      f"substeps {sim.substeps}; real-time factor (CPU) {2.5/cpu:.2f}x")
# 2. free wobble: the fluted jelly mould (not a test body), base pinned, gravity off, zeta 0
from jellysim.geometry.shapes import jelly_mould
from jellysim.geometry.mesh import Mesh
mesh = Mesh.from_arrays(*jelly_mould())
body = js.Body.from_mesh(mesh, size=0.08, points=1500, connect="marching")
model = js.physical_model(body, js.material("gelatin", damping_ratio=0.0), gravity=(0, 0, 0))
sim = js.Simulator(model, dt=1/60, threads=1)
y = model.point_x0[:, 1]; y0 = y.min(); H = y.max() - y0
sim.pin(np.flatnonzero(y < y0 + 0.08 * H))
sim.state.v[:, 0] = 0.05 * (y - y0) / H
top = np.flatnonzero(y > y0 + 0.9 * H)
u, E, c = [], [], time.process_time()
m = model.point_mass
for _ in range(120):
    sim.advance(1)
    u.append(sim.state.x[top, 0].mean() - model.point_x0[top, 0].mean())
    E.append(0.5 * m @ (sim.state.v**2).sum(1) + elastic_energy(model.fem, sim.state.x))
cpu = time.process_time() - c
u, E = np.array(u), np.array(E)
s = np.sign(u); up = np.flatnonzero((s[:-1] < 0) & (s[1:] >= 0))
tz = (up + u[up] / (u[up] - u[up + 1])) / 60
f = 1 / np.median(np.diff(tz)); periods = 2.0 * f
kept = (E[-30:].mean() / E[:30].mean()) ** (1 / periods)
print(f"wobble of the mould ({model.point_count} points): {f:.3f} Hz, {len(up)} upward crossings "
      f"(periods visible) in 2 s, energy kept per period {kept:.5f}, substeps {sim.substeps}, "
      f"real-time factor (CPU) {2.0/cpu:.2f}x")
