"""Lesson: the mass on a spring, T = 2 pi sqrt(M / k), with the jello hanging on a handle.

A 4 cm cube of firm gelatin (E = 1 MPa, so it moves almost as one mass) hangs from a spring of
k = 20 N/m fixed at its top (``Simulator.drag``: the spring ``jellysim view`` pulls the jello
with), released with the spring unstretched.  It falls and bobs about the point where the
spring carries its weight, M g / k below, and its lowest point is 2 M g / k down.  With the
spring's own damping ratio zeta the period grows to 2 pi sqrt(M/k) / sqrt(1 - zeta^2) and
the first overshoot is exp(-pi zeta / sqrt(1 - zeta^2)) of the drop to rest (the textbook's
dashpot: here it is the spring's, not the jello's).

    python examples/lessons/mass_on_spring.py            (prints each run beside its formula)

Measured: docs/lessons.md; tests/test_lessons.py runs it.
"""
from __future__ import annotations

import numpy as np

import jellysim as js

STIFFNESS = 20.0   # [N/m]
DT = 1.0 / 600.0   # [s] a frame


def hang(zeta: float = 0.0, seconds: float = 2.0):
    """Run the cube on the spring: ``(times [s], centre-of-mass heights [m], M [kg],
    g [m/s^2])``."""
    body = js.Body.box(lower=(0.0, 0.0, 0.0), upper=(0.04, 0.04, 0.04), points=64)
    model = js.physical_model(body, js.material("gelatin", youngs_modulus=1e6,
                                                damping_ratio=0.0))
    sim = js.Simulator(model, dt=DT)
    x = sim.state.x
    top = int(np.argmin(((x - [0.02, 0.04, 0.02]) ** 2).sum(axis=1)))   # the top's centre
    sim.drag(top, x[top].copy(), stiffness=STIFFNESS, damping_ratio=zeta)
    mass = model.point_mass                                  # [kg] per point
    times, heights = [], []
    for _ in range(int(round(seconds / DT))):
        sim.advance(1)
        times.append(sim.state.t)
        heights.append(float(mass @ sim.state.x[:, 1] / mass.sum()))
    return np.array(times), np.array(heights), float(mass.sum()), -float(model.gravity[1])


def measure(zeta: float = 0.0):
    """``(period [s], 2 pi sqrt(M/k) / sqrt(1 - zeta^2), lowest point [m below the start],
    M g / k (1 + exp(-pi zeta / sqrt(1 - zeta^2))) (2 M g / k undamped), first overshoot /
    drop to rest, exp(-pi zeta / sqrt(1 - zeta^2)))``."""
    t, y, mass, g = hang(zeta)
    rest = y[0] - mass * g / STIFFNESS                     # where the spring carries the weight
    u = y - rest
    k = np.flatnonzero(np.sign(u[:-1]) * np.sign(u[1:]) < 0)
    crossings = t[k] - u[k] * (t[k + 1] - t[k]) / (u[k + 1] - u[k])
    period = 2.0 * float(np.mean(np.diff(crossings)))
    low = int(np.argmin(y[: len(y) // 2]))
    overshoot = (rest - y[low]) / (y[0] - rest)
    over = float(np.exp(-np.pi * zeta / np.sqrt(1 - zeta**2)))
    return (period, 2 * np.pi * np.sqrt(mass / STIFFNESS) / np.sqrt(1 - zeta**2), y[0] - y[low],
            mass * g / STIFFNESS * (1 + over), overshoot, over)


if __name__ == "__main__":
    for zeta in (0.0, 0.1):
        period, t_formula, drop, drop_formula, over, over_formula = measure(zeta)
        print(f"zeta = {zeta}: period {period:.4f} s, 2 pi sqrt(M/k) / sqrt(1 - zeta^2) = "
              f"{t_formula:.4f} s; lowest point {1000 * drop:.1f} mm down, M g / k (1 + "
              f"overshoot) = {1000 * drop_formula:.1f} mm; first overshoot {over:.3f} of the "
              f"drop to rest, exp(-pi zeta / sqrt(1 - zeta^2)) = {over_formula:.3f}")
