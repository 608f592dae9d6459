"""The paper-2010 preset is the report's section 4.1 step, to 1e-12 m.

``report_steps`` below is a line-by-line transcription of the report's section 4.1 (read in
/work/shared/reference/jello-report-2010.txt), written here without calling jellysim's kernels:

1. "each of the points' positions are updated according to its velocity": x += v dt;
2. "then the velocities are updated using the points' acceleration": v += a dt;
3. "the acceleration is then updated using the forces on the point" by equation 1,
   a_i = (k sum_n Delta d_in - delta v_i) / m_i, plus gravity, Delta d_in the spring's stretch
   along the spring;
4. "We iterate over every point ... and for each of its neighbors, we do Provot correction"
   (Provot 1995: both ends move half the excess, in place), with "springs between all points"
   (rest length from the rest positions), once per loop ("one Provot correction loop");
   positions only (nothing is said of velocities);
5. the ground (equations 2 and 3): a point below y = 0 is put on it, v_y = 0, v_x, v_z *= mu,
   a_y -= nu a_y.

Accelerations start at zero.  The transcription is plain Python over numpy arrays; numba
compiles the same source only to make 100 all-pairs steps (18 M pair visits) take a second.

Why the sums' order is fixed here: at the landing the ground and the in-place Provot pass
amplify a rounding difference about 100x per step (a 1e-16 difference in one force sum grows to
3e-8 m five steps later), so agreement to 1e-12 m after 100 steps needs the same arithmetic:
each point's spring forces summed over its neighbours with larger index, then those with
smaller index, ``k (|d| - L0) / |d|`` times ``d``, and ``/ m`` as ``* (1 / m)``.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from numba import njit

from jellysim.scene import Scene

ROOT = Path(__file__).resolve().parent.parent


def report_steps(steps, x, v, a, x0, nbr_ptr, nbr, k, mass, delta, g, dt, tau, mu, nu):
    """``steps`` report steps in place on x [m], v [m/s], a [m/s^2] (n, 3);
    ``nbr[nbr_ptr[i]:nbr_ptr[i + 1]]``: point i's spring neighbours (the larger indices
    ascending, then the smaller ones ascending: the order the sums are taken in)."""
    n = x.shape[0]
    new_a = np.zeros((n, 3))
    for _ in range(steps):
        # 4.1: positions from velocities, then velocities from accelerations
        for i in range(n):
            for c in range(3):
                x[i, c] = x[i, c] + v[i, c] * dt
            for c in range(3):
                v[i, c] = v[i, c] + a[i, c] * dt
        # equation 1, point by point: a_i = (k sum_n Delta d_in - delta v_i) / m_i (+ gravity),
        # Delta d_in = (|d| - L0) d / |d| with d = x_n - x_i
        for i in range(n):
            f = np.zeros(3)
            for t in range(nbr_ptr[i], nbr_ptr[i + 1]):
                j = nbr[t]
                d = x[j] - x[i]
                length = np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
                r = x0[j] - x0[i]
                rest = np.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
                f += k * (length - rest) / length * d
            new_a[i] = (f - delta * v[i]) * (1.0 / mass[i]) + g
        a[:] = new_a
        # Provot over all pairs, every point in order, each neighbour in order, in place
        for i in range(n):
            for j in range(i + 1, n):
                d = x[j] - x[i]
                length = np.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2)
                r = x0[j] - x0[i]
                rest = np.sqrt(r[0] ** 2 + r[1] ** 2 + r[2] ** 2)
                if length > (1.0 + tau) * rest:
                    excess = length - (1.0 + tau) * rest
                elif length < (1.0 - tau) * rest:
                    excess = length - (1.0 - tau) * rest
                else:
                    continue
                move = excess / (2.0 * length) * d  # half the excess each, along the pair
                x[i] += move
                x[j] -= move
        # the ground y = 0: equations 2 and 3
        for i in range(n):
            if x[i, 1] < 0.0:
                x[i, 1] = 0.0
                v[i, 1] = 0.0
                v[i, 0] *= mu
                v[i, 2] *= mu
                a[i, 1] = a[i, 1] - nu * a[i, 1]


report_steps_compiled = njit(cache=False)(report_steps)


def neighbour_lists(n, springs):
    """Each point's spring neighbours, larger indices ascending then smaller ones ascending."""
    lists = [[] for _ in range(n)]
    for i, j in springs:
        lists[i].append(j)
        lists[j].append(i)
    ptr, nbr = [0], []
    for i, row in enumerate(lists):
        row = sorted(set(row))
        nbr += [j for j in row if j > i] + [j for j in row if j < i]
        ptr.append(len(nbr))
    return np.array(ptr, dtype=np.int64), np.array(nbr, dtype=np.int64)


def test_paper_preset_is_the_report_step_to_1e12_m():
    scene = Scene.load(ROOT / "examples" / "paper_2010_preset.toml")
    p = scene.params
    assert p["provot"]["order"] == "gauss-seidel" and not p["provot"]["velocity_update"]
    assert p["integrator"]["start_acceleration"] == "zero"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model = scene.build_model()
        sim = scene.simulator(model)
    assert model.point_count == 600
    sim.advance(100)

    body = model.body
    x0 = np.array(body.points, dtype=np.float64)
    springs = np.array(body.springs, dtype=np.int64)
    mass = np.full(len(x0), 1141.0 * 1.0 / len(x0))  # the density the report quotes for Jello x 1 m^3, even split
    assert np.allclose(model.point_mass, mass, rtol=1e-14)
    assert np.all(model.spring_stiffness == 2.0) and model.damping == 0.8
    x, v, a = x0.copy(), np.zeros_like(x0), np.zeros_like(x0)
    report_steps_compiled(100, x, v, a, x0, *neighbour_lists(len(x0), springs), 2.0, mass, 0.8,
                          np.array([0.0, -9.8, 0.0]), 0.01, 0.001, 0.1, 0.2)
    assert np.all(np.isfinite(x))
    assert np.abs(x.min(axis=0)[1]) < 1e-12  # it fell 0.5 m and landed within the 100 steps
    assert np.max(np.abs(sim.state.x - x)) < 1e-12
    assert np.max(np.abs(sim.state.v - v)) < 1e-9


def test_transcription_runs_the_same_in_plain_python():
    """The compiled transcription is the plain one: two steps of a small all-pairs box agree."""
    rng = np.random.default_rng(3)
    x0 = rng.random((12, 3)) + [0, 0.01, 0]
    springs = np.array([(i, j) for i in range(12) for j in range(i + 1, 12)
                        if np.linalg.norm(x0[i] - x0[j]) < 0.6], dtype=np.int64)
    args = (*neighbour_lists(12, springs), 50.0, np.full(12, 0.3), 0.8,
            np.array([0.0, -9.8, 0.0]), 0.01, 0.001, 0.1, 0.2)
    runs = []
    for fn in (report_steps, report_steps_compiled):
        x, v, a = x0.copy(), np.zeros_like(x0), np.zeros_like(x0)
        v[:, 1] = -1.5  # so that some points reach the ground
        fn(3, x, v, a, x0, *args)
        runs.append((x, v, a))
    for p, q in zip(*runs):
        assert np.max(np.abs(p - q)) < 1e-14
    assert np.any(runs[0][0][:, 1] == 0.0)


def test_paper_preset_splits_the_mass_evenly_whatever_the_builder(tmp_path):
    """The report gives no masses: the preset splits the body's mass evenly over its points.
    Tet builders lump it by tet volume, so under the paper preset a Delaunay body of Spot had point masses
    from 2e-6 to 0.6 kg, a stability limit of 5e-7 s, and stopped at step 6 (session 11's
    trial).  Under the preset every builder's points now weigh density x volume / n, and the
    run at the report's dt = 0.01 s stays finite and on or above the report's ground."""
    mesh = Path(__file__).parent / "data" / "spot.obj"
    for connect in ("delaunay", "marching", "radius"):
        text = (f'[material]\npreset = "paper-2010"\n[body]\ntype = "mesh"\npath = "{mesh}"\n'
                f'points = 300\nsize = 1.0\nbase = [0.0, 0.2, 0.0]\n[springs]\nconnect = '
                f'"{connect}"\n' + ('radius = 0.25\n' if connect == "radius" else "")
                + '[integrator]\nsteps = 25\n')
        scene = Scene.from_text(text, name=f"{connect}.toml")
        model = scene.build_model()
        m = np.asarray(model.point_mass, dtype=np.float64)
        volume = model.body.volume
        assert np.ptp(m) == 0.0, connect
        assert m.sum() == pytest.approx(1141.0 * volume, rel=1e-12), connect
        sim = scene.simulator(model)
        sim.advance(scene.steps)
        assert np.all(np.isfinite(sim.state.x)) and sim.state.x[:, 1].min() > -1e-9, connect


def test_the_paper_cubes_outcome_hinges_on_the_mass_the_report_does_not_give():
    """README and `examples/paper_cube.toml`: at the 1.9 kg a point we chose (the density the
    report quotes for real Jello) the report's step, which never takes back the speed Provot's
    moves leave, splashes: at 1 s the cube is 1.39 x 1.26 x 1.29 m, its fastest point moves at
    8.6 m/s and its kinetic + gravitational energy has nearly doubled; with 0.01 kg a point the
    same step keeps the cube (session 29's report trial)."""
    example = Path(__file__).parents[1] / "examples" / "paper_cube.toml"
    out = {}
    for pm in (None, 0.01):
        scene = Scene.load(example, overrides=() if pm is None else (f"mass.point_mass={pm}",))
        model = scene.build_model()
        sim = scene.simulator(model)
        m = np.asarray(model.point_mass, dtype=np.float64)

        def energy():
            x, v = sim.state.x, sim.state.v
            return 0.5 * m @ (v * v).sum(1) + 9.8 * m @ x[:, 1]

        e0 = energy()
        sim.advance(100)
        out[pm] = (np.ptp(sim.state.x, axis=0), np.linalg.norm(sim.state.v, axis=1).max(),
                   energy() / e0)
    extent, fastest, gain = out[None]  # (1.39 x 1.26 x 1.29 m, 8.57 m/s, 11 -> 20 kJ)
    assert extent.min() > 1.2 and fastest > 5.0 and gain > 1.5
    extent, fastest, gain = out[0.01]  # (1.00 x 1.00 x 1.00 m, 0.12 m/s)
    assert np.allclose(extent, 1.0, atol=0.01) and fastest < 0.5 and gain < 1.0
